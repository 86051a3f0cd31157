"""What the node's helpers (the demo sweep, the plan requests) use of the node: a Protocol, so
they do not import the node that imports them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from builtin_interfaces.msg import Time

from .core.model import Mechanism
from .core.solver import Result
from .engine import Engine
from .params import NodeConfig
from .publishing import Outputs


class ServingNode(Protocol):
    """The parts of :class:`~linkage_ros.node.LinkageNode` its helpers call."""

    config: NodeConfig
    engine: Engine | None
    outputs: Outputs | None
    frame_id: str
    max_names: int

    def _served_engine(self) -> Engine: ...

    def _served_mech(self) -> Mechanism: ...

    def _answer(self, request: str, stamp: Any, solve: Callable[[], Result]) -> Result: ...

    def _refuse_waiting(self, request: str) -> Result: ...

    def _request_stamp(self, stamp: Time) -> tuple[Time, str | None]: ...

    def create_timer(self, timer_period_sec: float, callback: Callable[[], Any]) -> Any: ...

    def destroy_timer(self, timer: Any) -> bool: ...

    def get_logger(self) -> Any: ...

    def set_parameters(self, parameter_list: list[Any]) -> Any: ...
