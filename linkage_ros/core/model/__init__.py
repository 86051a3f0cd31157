"""Scene / mechanism model.

A mechanism is described the way the graphical ("tracing paper") method sees it: named points
with coordinates in one reference pose; links as rigid sets of those points; revolute joints where
links share a point; prismatic joints (a slider point on a line fixed in a guide link); actuators
that are an angle (crank) or a slide (a prismatic joint's throw, e.g. a hydraulic cylinder's
pin-to-pin length). Link geometry and the default assembly mode come from the reference pose.

Shortcut forms (``four_bar``, ``slider_crank``) compile into the same general form, so one
validator serves every scene. See docs/SCENES.md for the file format.
"""

from __future__ import annotations

from .actuators import _limits  # noqa: F401
from .checks import (  # noqa: F401
    TOP_KEYS,
    _Ctx,
)
from .general import (  # noqa: F401
    _build_general,
    _length_scale,
    _make_link,
    build_mechanism,
)
from .mechanism import (  # noqa: F401
    NAME_RE,
    SOLVERS,
    Actuator,
    AngleActuator,
    Link,
    Mechanism,
    PrismaticJoint,
    RevoluteJoint,
    SlideActuator,
)
from .scene import (  # noqa: F401
    MAX_NUMBER_CHARS,
    MAX_SCENE_BYTES,
    MAX_SCENE_DEPTH,
    Scene,
    _UniqueKeyLoader,
)
from .shortcuts import (  # noqa: F401
    _branch,
    _crank_actuator,
    _four_bar_to_general,
    _reference_input,
    _slider_crank_to_general,
)
