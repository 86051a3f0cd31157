"""Scene / mechanism model.

A mechanism is described the way the graphical ("tracing paper") method sees it: named points
with coordinates in one reference pose; links as rigid sets of those points; revolute joints where
links share a point; prismatic joints (a slider point on a line fixed in a guide link); actuators
that are an angle (crank) or a slide (a prismatic joint's throw, e.g. a hydraulic cylinder's
pin-to-pin length). Link geometry and the default assembly mode come from the reference pose.

Shortcut forms (``four_bar``, ``slider_crank``) compile into the same general form, so one
validator serves every scene. See docs/SCENES.md for the file format.

The types (Mechanism, links, joints, actuators) live in core.mechanism, a leaf the Newton module
reads too: building a scene may redraw it on the Newton module (model.redraw), and Newton must
not import this package back (no import circle, test_import_graph).
"""

from __future__ import annotations

from ..mechanism import (
    METHODS,
    NAME_RE,
    Actuator,
    AngleActuator,
    Link,
    Mechanism,
    PrismaticJoint,
    RevoluteJoint,
    SceneForm,
    SlideActuator,
    SolveMethod,
)
from .checks import (
    TOP_KEYS,
)
from .general import (
    build_mechanism,
)
from .scene import (
    MAX_NUMBER_CHARS,
    MAX_SCENE_BYTES,
    MAX_SCENE_DEPTH,
    Scene,
)

__all__ = [
    'Actuator',
    'AngleActuator',
    'build_mechanism',
    'Link',
    'MAX_NUMBER_CHARS',
    'MAX_SCENE_BYTES',
    'MAX_SCENE_DEPTH',
    'Mechanism',
    'NAME_RE',
    'PrismaticJoint',
    'RevoluteJoint',
    'Scene',
    'SlideActuator',
    'METHODS',
    'SceneForm',
    'SolveMethod',
    'TOP_KEYS',
]
