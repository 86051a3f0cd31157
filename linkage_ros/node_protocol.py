"""What the node's helpers (the requests, the demo sweep, the plan requests) use of the node: a
Protocol, so they do not import the node that imports them."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from builtin_interfaces.msg import Time

from .core.model import Mechanism
from .core.solver import Result
from .engine import Engine
from .params import NodeConfig
from .publishing import Outputs, Waiting


class Answering(Protocol):
    """What the node's helpers call of its requests (node_requests.Requests)."""

    def served_engine(self) -> Engine: ...

    def served_mech(self) -> Mechanism: ...

    def answer(
        self, request: str, stamp: Any, solve: Callable[[], Result], from_client: bool = True
    ) -> Result: ...

    def refuse_waiting(self, request: str) -> Result: ...

    def request_stamp(self, stamp: Time) -> tuple[Time, str | None]: ...


class ServingNode(Protocol):
    """The parts of :class:`~linkage_ros.node.LinkageNode` its helpers call."""

    config: NodeConfig
    engine: Engine | None
    mech: Mechanism | None
    outputs: Outputs | None
    waiting: Waiting | None
    frame_id: str
    max_names: int
    max_request_bytes: int
    #: state completion: the inputs read from joint_states_in, and mimic followers among them
    state_inputs: frozenset[str]
    state_followers: frozenset[str]

    @property
    def requests(self) -> Answering: ...

    def get_clock(self) -> Any: ...

    def create_timer(self, timer_period_sec: float, callback: Callable[[], Any]) -> Any: ...

    def destroy_timer(self, timer: Any) -> bool: ...

    def get_logger(self) -> Any: ...

    def set_parameters(self, parameter_list: list[Any]) -> Any: ...
