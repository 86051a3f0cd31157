"""Compile (mechanism, known quantities, wanted outputs) into a closed-form solve plan.

Known quantities are *specs*: an actuator or joint value, a link's angle, or a point's (x, y).
A known joint value between two links that share a point welds them into one rigid *body*
(a crank at a known angle is welded to the ground; a cylinder at a known throw is one rigid
strut). The plan then places bodies exactly as the graphical "tracing paper" method does:

* ``two_points``   a body with two known points is placed (rigid transfer),
* ``point_angle``  a body with a known point and a known orientation is placed,
* ``circle_circle`` (RRR) a point shared by two bodies that each have one known point,
* ``circle_line``   (RRP) a slider point on a known guide line and on a body with one known point,
* ``line_through``  (RPR) a guide body pivoting on a known point whose line must pass a known point.

Every branching step carries an explicit sign; the default is the sign seen in the reference pose.
The plan is pruned backwards to the steps the wanted outputs depend on, and is cached by the
caller per (mechanism, knowns, outputs). Execution is vectorised over a leading batch axis.
"""

from __future__ import annotations

from ..quantities import AngleSpec, PointSpec, ScalarSpec, SlideSpec, Spec
from .compile import (
    Body,
    Plan,
    Step,
    Weld,
    run_one,
)
from .geometry import (
    branch_geometry_of,
    branch_geometry_one,
    rollers_off_drawn_side,
    step_geometry,
)
from .poses import (
    Poses,
    ScalarPoses,
    ScalarRun,
    batch_poses,
    link_poses,
    reference_poses,
)
from .spec import (
    KNOWN_KINDS,
    ReadKind,
    SpecReader,
    limit_violation,
    needs_beyond_limits,
    spec_for,
    spec_point_link,
    spec_reader,
    spec_value_at,
    spec_value_of,
    spec_value_one,
    value_interval,
)

__all__ = [
    'AngleSpec',
    'batch_poses',
    'Body',
    'branch_geometry_of',
    'branch_geometry_one',
    'KNOWN_KINDS',
    'limit_violation',
    'link_poses',
    'needs_beyond_limits',
    'Plan',
    'PointSpec',
    'Poses',
    'ReadKind',
    'reference_poses',
    'rollers_off_drawn_side',
    'run_one',
    'ScalarPoses',
    'ScalarRun',
    'ScalarSpec',
    'SlideSpec',
    'Spec',
    'spec_for',
    'spec_point_link',
    'spec_reader',
    'spec_value_at',
    'spec_value_of',
    'spec_value_one',
    'SpecReader',
    'Step',
    'step_geometry',
    'value_interval',
    'Weld',
]
