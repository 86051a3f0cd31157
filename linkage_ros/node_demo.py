"""The demo sweep on the node: a timer at ``demo_rate`` commanding the first actuator, so joint
states flow without any command (values: demo.DemoSweep)."""

from __future__ import annotations

from typing import Any

from builtin_interfaces.msg import Time
from rclpy.parameter import Parameter

from .conversions import format_joints
from .demo import DemoSweep
from .node_protocol import ServingNode

#: failed demo solves in a row that stop the demo (and set demo_sweep false)
DEMO_FAILURES = 3


class DemoRunner:
    """The demo of one node: :meth:`start` on the mechanism served, :meth:`stop`; answered as a
    command is (request 'demo'); DEMO_FAILURES failures in a row stop it and set the parameter
    demo_sweep false (setting it true again restarts it)."""

    def __init__(self, node: ServingNode):
        self.node = node
        self.timer: Any = None
        self.sweep: DemoSweep | None = None
        self.failures = 0

    def start(self) -> None:
        node = self.node
        mech, last = node.requests.served_mech(), node.requests.served_engine().last
        first = next(iter(mech.actuators))
        start = last.inputs[first] if last else 0.0
        self.sweep = DemoSweep(mech, first, start)
        self.failures = 0
        self.timer = node.create_timer(1.0 / node.config.demo_rate, self._tick)
        node.get_logger().info(f'demo sweep of {first!r} at {node.config.demo_rate:g} Hz')

    def stop(self) -> None:
        if self.timer is not None:
            self.node.destroy_timer(self.timer)
            self.timer = None

    def _tick(self) -> None:
        node, sweep = self.node, self.sweep
        engine, mech = node.requests.served_engine(), node.requests.served_mech()
        assert sweep is not None  # the timer runs only with a sweep
        last = engine.last
        values = dict(last.inputs) if last else {a: 0.0 for a in mech.actuators}
        values[sweep.name] = sweep.next()
        # the node's own sweep: no client waits on it, so it does not pace plans
        result = node.requests.answer(
            'demo', Time(), lambda: engine.command(values), from_client=False
        )
        log = node.get_logger()
        if result.success:
            self.failures = 0
            log.info(
                format_joints(result, mech.joint_names, list(mech.actuators)),
                throttle_duration_sec=0.5,
            )
            return
        self.failures += 1
        sweep.bounce(values[sweep.name])
        if self.failures >= DEMO_FAILURES:
            log.error(
                f'demo sweep stopped: {result.reason} (demo_sweep is now false; set it to '
                'true to restart)'
            )
            self.stop()
            # the parameter says what runs: setting it true again restarts the sweep
            node.set_parameters([Parameter('demo_sweep', value=False)])
