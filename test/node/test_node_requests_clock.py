"""Every client request the node answers stamps its CommandClock (the plan worker paces
itself by it: plan_worker.Pacer); the node's own demo sweep and a request refused while no
robot description is served do not."""

from __future__ import annotations

import math
import time
from types import SimpleNamespace

from builtin_interfaces.msg import Time

from linkage_ros.core.solver import Result
from linkage_ros.node_requests import Requests
from linkage_ros.plan_worker import CommandClock


class _Outputs:
    def __init__(self) -> None:
        self.answered: list[str] = []

    def answer(self, result: Result, stamp: Time, request: str) -> None:
        self.answered.append(request)


def test_an_answered_request_stamps_the_command_clock():
    outputs = _Outputs()
    node = SimpleNamespace(outputs=outputs)
    clock = CommandClock()
    requests = Requests(node, clock)  # type: ignore[arg-type]
    assert clock.last() == -math.inf
    before = time.monotonic()
    requests.answer('command', Time(sec=1, nanosec=0), lambda: Result(False, 'refused'))
    after = time.monotonic()
    assert outputs.answered == ['command']
    assert before <= clock.last() <= after


def test_the_demo_sweep_leaves_the_clock_alone():
    # the node's own sweep (node_demo) is no client's command: plans run at full speed beside it
    node = SimpleNamespace(outputs=_Outputs())
    clock = CommandClock()
    Requests(node, clock).answer(  # type: ignore[arg-type]
        'demo', Time(sec=1), lambda: Result(False, 'x'), from_client=False
    )
    assert clock.last() == -math.inf


def test_a_request_before_any_robot_description_leaves_the_clock_alone():
    waiting = SimpleNamespace(answer=lambda request: None, reason=lambda: 'waiting')
    node = SimpleNamespace(outputs=None, waiting=waiting)
    clock = CommandClock()
    Requests(node, clock).answer('command', Time(sec=1), lambda: Result(True))  # type: ignore[arg-type]
    assert clock.last() == -math.inf
