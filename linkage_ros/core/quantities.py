"""The typed vocabulary of known (or wanted) quantities: one frozen dataclass per kind, matched
with isinstance / match, never a kind string. Resolving a name to one (actuator, joint, link,
point) is core.plan.spec's; this module has no dependencies, so every layer can use it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar


@dataclass(frozen=True)
class Shown:
    """How a robot description writes an actuator's value: ``scale * (value - offset)``
    (scale +-1: its joint turns about the plane's normal or against it; offset: its zero
    pose). Refusals quote limits and values this way (core.plan.spec.limit_violation)."""

    scale: float
    offset: float

    def __call__(self, value: float) -> float:
        return self.scale * (value - self.offset)


@dataclass(frozen=True)
class AngleSpec:
    """phi[link] - phi[reference] = value - offset (rad; 1 value). ``minimum``/``maximum``:
    an actuator's limits (compared on the circle)."""

    name: str
    link: str
    reference: str
    offset: float = 0.0
    minimum: float | None = None
    maximum: float | None = None
    #: a robot description's own value of this actuator (None: the scene's is the user's)
    shown: Shown | None = None
    size: ClassVar[int] = 1
    unit: ClassVar[str] = 'rad'
    periodic: ClassVar[bool] = True

    @property
    def bounded(self) -> bool:
        """Whether some values are refused (limit_violation): it has a limit."""
        return self.minimum is not None or self.maximum is not None


@dataclass(frozen=True)
class SlideSpec:
    """The value of prismatic joint ``joint`` (m; 1 value), with an actuator's limits."""

    name: str
    joint: str
    minimum: float | None = None
    maximum: float | None = None
    #: a robot description's own value of this actuator (None: the scene's is the user's)
    shown: Shown | None = None
    #: a cylinder's pin-to-pin length: > 0 whatever its limits say
    length: bool = False
    size: ClassVar[int] = 1
    unit: ClassVar[str] = 'm'
    periodic: ClassVar[bool] = False

    @property
    def bounded(self) -> bool:
        """Whether some values are refused (limit_violation): a limit, or a length."""
        return self.length or self.minimum is not None or self.maximum is not None


@dataclass(frozen=True)
class PointSpec:
    """The world position of ``point`` (m; 2 values x, y)."""

    name: str
    point: str
    size: ClassVar[int] = 2
    unit: ClassVar[str] = 'm'


@dataclass(frozen=True)
class CoordinateSpec:
    """One world coordinate of ``point`` (m; 1 value): x (``axis`` 0) or y (1), the other left
    to the mechanism, as the loader lecture poses its bin: "only the x-coordinate and the
    orientation of this bin, and the y-coordinate will be automatically decided". No limits
    (the fields are there so every one-value known reads alike)."""

    name: str
    point: str
    axis: int
    minimum: None = None
    maximum: None = None
    shown: None = None
    size: ClassVar[int] = 1
    unit: ClassVar[str] = 'm'
    periodic: ClassVar[bool] = False
    bounded: ClassVar[bool] = False


#: one known (or wanted) quantity of a mechanism
Spec = AngleSpec | SlideSpec | PointSpec | CoordinateSpec
#: a known with one value (angle, slide or one coordinate); angles and slides may carry limits
ScalarSpec = AngleSpec | SlideSpec | CoordinateSpec
