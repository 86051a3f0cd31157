"""Motion limits, reachable regions and tilt ranges of a mechanism (pure numpy / scipy).

Everything here is built on :class:`~linkage_ros.core.solver.Solver` (its compiled dyad plan for
vectorised scans, its continuation solves for walks) and returns plain data (dicts, tuples,
lists of floats); nothing prints.

* :func:`input_ranges` / :func:`actuator_range` / :func:`actuator_ranges`: the range of each
  actuator with the others held at their reference-pose values (each scanned on the independent
  part of the scene it moves, :mod:`.components`). The assembly is scanned over a full turn
  (angles) or over the scene's [min, max] (slides; a generous bracket around the reference throw
  when a side has no limit), each boundary is refined to 1e-12 rad / 1e-12 of the length scale
  (a toggle position; where Newton places the scene, the last value its solve closes to its
  tolerance: up to ~1e-10 past the toggle, where Newton still converges on the far side),
  and the result is intersected with the actuator's own limits.
* :func:`toggle_positions`: input values where a dyad of the assembly has a toggle (margin -> 0).
* :func:`oscillation_range`: the range of a link's angle while an input runs over its range (the
  oscillation of a rocker, of both links of a non-Grashof chain, ...).
* :func:`reachable_region`: the region a point reaches while the actuators run over their limits
  (the seed's "zone of hinge K"): with two actuators, the four extreme arcs (each actuator at its
  min or max while the other sweeps) joined into a polygon, checked against a sampled cloud.
* :func:`max_tilt`: the largest rotation of a link (the bin) about one of its points (the lip)
  held fixed, within the actuator limits: an inverse-kinematics walk with knowns [lip, link].

Circuits. A single-DOF scan follows the mechanism through its assembly modes the way it moves:
it starts in the reference pose's mode; where a dyad toggles (the scanned input reaches an
extreme) the motion continues in the mode with that dyad's sign flipped, with the input running
back. The range of the input is the union over the circuit so found, which is exact for
single-loop chains (both modes of a four-bar's dyad cover the same input interval) and follows
the physical motion for multi-loop ones. Scanning samples the circuit on a grid (``samples``
per full turn / bracket), so an assembly gap narrower than one grid step can be missed.

Angle conventions (rad): a range that does not cover the full turn is reported as (min, max) with
min < max, the motion going counter-clockwise from min to max; max may exceed pi (a reachable set
spanning angle pi or 0/2pi is one interval, e.g. (0.40, 5.88)). Where a bound is the scene's own
limit, that limit is reported as written in the scene; otherwise min lies in [-pi, pi).
A full turn without limits is (None, None).
"""

from __future__ import annotations

from .common import (  # noqa: F401
    ANGLE_TOL,
    KARY,
    LENGTH_TOL,
    MAX_SEGMENTS,
    TOUCHED_TOGGLE_MARGIN,
    TWO_PI,
    clip_periodic,
    input_limits_lifted,
    limits_lifted,
    link_key,
    point_key,
    reference_point,
    reference_scalar,
    reference_value,
    without_limits,
)
from .oscillation import (  # noqa: F401
    oscillation_range,
)
from .ranges import (  # noqa: F401
    actuator_range,
    actuator_ranges,
    input_ranges,
    scan_circuit,
    toggle_positions,
)
from .region import (  # noqa: F401
    distance_to_polygon,
    points_in_polygon,
    reachable_region,
)
from .scan import (  # noqa: F401
    ScanLine,
    Segment,
    held_reference,
    slide_bracket,
)
from .tilt import (  # noqa: F401
    max_tilt,
)
from .touches import (  # noqa: F401
    golden_min,
)
from .walk import (  # noqa: F401
    walk_commands,
    walk_range,
)

__all__ = [
    'input_ranges',
    'actuator_range',
    'actuator_ranges',
    'toggle_positions',
    'oscillation_range',
    'reachable_region',
    'max_tilt',
    'reference_point',
    'reference_scalar',
    'reference_value',
    'without_limits',
    'input_limits_lifted',
    'limits_lifted',
    'point_key',
    'link_key',
    'points_in_polygon',
    'distance_to_polygon',
]
