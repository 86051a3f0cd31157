"""The node's spin loop (node_runtime.spin_until_stopped) on both executors it may run: it
stops when a stop is asked for, and it does not keep one future for the node's life (the
executor adds a done-callback to the future it waits on and never removes it, so a kept
future grew without bound: two callbacks every 0.1 s poll)."""

from __future__ import annotations

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor

from linkage_ros.node_runtime import StopOnSignal, spin_until_stopped

POLLS = 5


def _executors():
    out = [SingleThreadedExecutor]
    try:
        from rclpy.experimental import EventsExecutor
    except ImportError:
        return out
    return [*out, EventsExecutor]


@pytest.mark.parametrize('make', _executors(), ids=lambda m: m.__name__)
def test_the_spin_loop_waits_on_a_new_future_each_poll_and_stops_when_asked(make):
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        executor = make(context=context)
        stop = StopOnSignal()
        waited_on = []

        class Recording:  # the executor, its waits recorded (a C++ executor takes no patch)
            def spin_until_future_complete(self, future, timeout_sec=None):
                waited_on.append(future)
                executor.spin_until_future_complete(future, timeout_sec=0.001)
                if len(waited_on) == POLLS:
                    stop.requested = 2  # as SIGINT would

        spin_until_stopped(Recording(), stop, context)
        assert len(waited_on) == POLLS
        assert len({id(f) for f in waited_on}) == POLLS, 'one future kept across polls'
        executor.shutdown()
    finally:
        rclpy.try_shutdown(context=context)
