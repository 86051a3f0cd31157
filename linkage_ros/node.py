"""``linkage_node``: planar-mechanism kinematics served over ROS 2 topics.

A thin shell around the core (see docs/TOPICS.md for the full interface):

* ``~/command``  sensor_msgs/JointState (actuator names, rad or m)   -> forward kinematics
* ``~/target``   sensor_msgs/JointState (joint/link/actuator names)  -> inverse kinematics
* ``~/target_point/<point>`` geometry_msgs/PointStamped              -> inverse kinematics
* publishes ``joint_states``, ``~/points/<name>``, ``~/markers`` and one ``~/status`` per request.

Each callback is message -> plain data (conversions) -> core Solver -> message. A bad request is
answered by exactly one ERROR status and changes nothing; the node keeps the last good state.
"""

from __future__ import annotations

import dataclasses
import gc
import signal
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from builtin_interfaces.msg import Time
from geometry_msgs.msg import PointStamped, PoseStamped
from nav_msgs.msg import Path
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.exceptions import InvalidParameterTypeException, ParameterException
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import deserialize_message
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from .conversions import (
    format_joints,
    is_zero_stamp,
    joint_state_peek,
    joint_state_rates,
    joint_state_to_command,
    point_stamped_to_xy,
    pose_to_xy_yaw,
)
from .core.errors import CommandError, SceneError
from .core.solver import Result
from .core.solver.modes import reference_toggle_warnings
from .demo import DemoSweep
from .engine import max_request_names, request_shape_error
from .params import (
    DEMO_RATE_MAX,
    DEMO_RATE_MIN,
    NODE_NAME,
    PARAMETERS,
    QUEUE_DEPTH_MAX,
    ConfigError,
    NodeConfig,
    check_demo_rate,
    fail_setting,
    load_engine,
    make_config,
)
from .point_coordinates import pose_target
from .publishing import Outputs, topic_qos
from .stamps import frame_error, stamp_error
from .trajectory import TrajectoryAnswer, answer_path_msg, answer_trajectory_msg

__all__ = [
    'DEMO_RATE_MAX',
    'DEMO_RATE_MIN',
    'NODE_NAME',
    'PARAMETERS',
    'QUEUE_DEPTH_MAX',
    'ConfigError',
    'LinkageNode',
    'NodeConfig',
    'load_engine',
    'main',
    'make_config',
]

ZERO_CLOCK = (
    "header.stamp is 0, and so is the node clock's now: use_sim_time is true and no "
    '/clock message has arrived yet; stamp the request, or wait for /clock'
)


# ---- the ROS node --------------------------------------------------------------------------------


class LinkageNode(Node):
    """The ROS shell: parameters -> NodeConfig -> Engine; topics in, topics out."""

    def __init__(self, **kwargs):
        super().__init__(NODE_NAME, **kwargs)
        try:
            self._setup()
        except BaseException:
            self.destroy_node()
            raise

    # -- set-up ----------------------------------------------------------------------------------
    def _declare_parameters(self) -> dict[str, Any]:
        values = {}
        for p in PARAMETERS:
            desc = ParameterDescriptor(
                description=p.description,
                read_only=p.read_only,
                additional_constraints=p.constraints,
            )
            default = Parameter.Type.STRING_ARRAY if p.default == 'string_array' else p.default
            try:
                param = self.declare_parameter(p.name, default, desc)
            except InvalidParameterTypeException as exc:
                kind = (
                    type(p.default).__name__ if p.default != 'string_array' else 'list of strings'
                )
                kind = {
                    'float': 'a double (write 1.0, not 1)',
                    'int': 'an integer',
                    'str': 'a string',
                    'bool': 'a bool',
                }.get(kind, 'a ' + kind)
                raise ConfigError(f'parameter {p.name!r}: must be {kind} ({exc})') from None
            except ParameterException as exc:
                raise ConfigError(f'parameter {p.name!r}: {exc}') from None
            values[p.name] = param.value
        return values

    def _setup(self):
        self.config = make_config(self._declare_parameters())
        self.scene, self.engine = load_engine(self.config)
        mech = self.mech = self.scene.mechanism
        self.max_names = max_request_names(mech)  # a longer request is refused at once
        self.frame_id = self.config.frame_id or mech.frame_id
        self.outputs = Outputs(self, self.engine, self.config, self.frame_id)
        # ~/command and ~/target keep rclpy's default QoS-event warnings; the per-point targets
        # carry none (see Outputs: each handler costs every executor wakeup)
        qos = topic_qos(self.config.queue_depth)
        self.create_subscription(JointState, '~/command', self._on_command, qos)
        # targets arrive serialised: a request with more names than the scene has is refused
        # from its first bytes, before rclpy would build 10^5 Python strings for it
        self.create_subscription(JointState, '~/target', self._on_target, qos, raw=True)
        self.create_subscription(
            JointState,
            '~/target_any_mode',
            self._on_target_any_mode,
            qos,
            event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
            raw=True,
        )
        ground = set(mech.links[mech.ground].points)
        self.target_points = [p for p in mech.points if p not in ground]
        quiet_sub = SubscriptionEventCallbacks(use_default_callbacks=False)
        for p in self.target_points:
            self.create_subscription(
                PointStamped,
                f'~/target_point/{p}',
                lambda msg, p=p: self._on_target_point(p, msg),
                qos,
                event_callbacks=quiet_sub,
            )
        # a link's pose (its first point and its angle) from a PoseStamped, e.g. a TF pose
        self.pose_links = [l for l in mech.links if l != mech.ground]
        for link in self.pose_links:
            self.create_subscription(
                PoseStamped,
                f'~/target_pose/{link}',
                lambda msg, link=link: self._on_target_pose(link, msg),
                qos,
                event_callbacks=quiet_sub,
            )
        # trajectories and paths: many requests answered as one (trajectory.py)
        self.create_subscription(
            JointTrajectory, '~/trajectory', self._on_trajectory, qos, event_callbacks=quiet_sub
        )
        for p in self.target_points:
            self.create_subscription(
                Path,
                f'~/target_path/{p}',
                lambda msg, p=p: self._on_target_path(p, msg),
                qos,
                event_callbacks=quiet_sub,
            )
        self._demo_timer = None
        self._demo: DemoSweep | None = None
        self._demo_failures = 0
        self.add_on_set_parameters_callback(self._on_set_parameters)
        log = self.get_logger()
        log.info(
            f'scene {mech.name!r} from {self.config.scene_path}: {mech.dof} DOF, '
            f'actuators {list(mech.actuators)}, joints {mech.joint_names}, outputs '
            f'{list(mech.outputs)}, frame {self.frame_id!r}, solver '
            f'{self.engine.forward.mode}, branch {self.config.branch}'
            + (
                ', dimensions ' + ', '.join(f'{k}={v:.12g}' for k, v in mech.stated.items())
                if mech.stated
                else ''
            )
        )
        for warning in reference_toggle_warnings(self.engine.forward):
            log.warning(f'scene {mech.name!r}: {warning}')
        if mech.dof > 2 and not self.config.target_point_hold:
            log.warning(
                f'{mech.dof}-DOF scene: ~/target_point/<point> needs target_point_hold '
                f'naming {mech.dof - 2} held value(s)'
            )
        # rclpy keeps an override this node never declares without a word: a misspelt name
        # would silently leave its parameter at the default
        overrides = getattr(self, '_parameter_overrides', None) or {}
        ignored = sorted(n for n in overrides if not self.has_parameter(n))
        if ignored:
            log.warning(
                f'ignoring parameter(s) this node does not have: {ignored} (its '
                f'parameters: {", ".join(p.name for p in PARAMETERS)})'
            )
        # the last start-up line: whoever waits for it has every start-up warning already
        log.info(
            f'listening on {self.resolve_topic_name("~/command")} (sensor_msgs/JointState '
            f'{list(mech.actuators)}), publishing {self.resolve_topic_name("joint_states")} '
            f'(reliable, keep last {self.config.output_depth}; commands keep last '
            f'{self.config.queue_depth})'
        )
        if self.config.demo_sweep:
            self._check_demo_possible()
            self._start_demo()
        # another node of this name in this namespace mixes its answers, status and parameter
        # services with ours: look at the graph once discovery has had time to see it
        self._clash_checks = 0
        self._clash_timer = self.create_timer(CLASH_CHECK_S, self._check_name_clash)

    def _check_name_clash(self) -> None:
        """Log an error if the graph holds another node with this node's full name (checked a
        few times during the first seconds, then never again)."""
        self._clash_checks += 1
        me = (self.get_name(), self.get_namespace())
        count = sum(1 for n in self.get_node_names_and_namespaces() if n == me)
        if count > 1 or self._clash_checks >= CLASH_CHECKS:
            self._clash_timer.cancel()
            self.destroy_timer(self._clash_timer)
        if count > 1:
            full = self.get_fully_qualified_name()
            self.get_logger().error(
                f'{count} nodes named {full} are running: their joint_states, status and '
                'parameter services mix and requests reach both; start each with its own '
                'name or namespace (--ros-args -r __node:=NAME or -r __ns:=/NS)'
            )

    # -- parameters at runtime -------------------------------------------------------------------
    def _on_set_parameters(self, params):
        """Check and apply demo_sweep / demo_rate. Never raises: a refused change (or one that
        fails unexpectedly) leaves the parameters, the config and the demo timer as they were."""
        old = cfg = self.config
        try:
            for p in params:
                if p.name == 'demo_sweep':
                    if not isinstance(p.value, bool):
                        fail_setting('demo_sweep', 'must be true or false', p.value)
                    if p.value:
                        self._check_demo_possible()
                    cfg = dataclasses.replace(cfg, demo_sweep=p.value)
                elif p.name == 'demo_rate':
                    cfg = dataclasses.replace(cfg, demo_rate=check_demo_rate(p.value))
        except ConfigError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        if cfg != old:
            try:
                self._apply_demo(cfg)
            except Exception as exc:  # e.g. a timer rclpy refuses: keep the old demo
                self.get_logger().error(
                    f'parameter change {[p.name for p in params]} refused: '
                    f'{exc!r}\n' + traceback.format_exc()
                )
                try:
                    self._apply_demo(old)
                except Exception as again:  # noqa: BLE001 - still never raise from here
                    self.get_logger().error(f'could not restore the demo either: {again!r}')
                return SetParametersResult(successful=False, reason=f'internal error: {exc!r}')
        return SetParametersResult(successful=True)

    def _apply_demo(self, cfg: NodeConfig):
        self._stop_demo()
        self.config = cfg
        if cfg.demo_sweep:
            self._start_demo()

    # -- requests ----------------------------------------------------------------------------------
    def _request_stamp(self, stamp: Time) -> tuple[Time, str | None]:
        """The stamp a request's answers carry (an unset one: the node clock's now), and why
        the request is refused for it, if it is."""
        if is_zero_stamp(stamp):  # unset: the node clock's now
            stamp = self.get_clock().now().to_msg()
            if is_zero_stamp(stamp):  # sim time before the first /clock
                return stamp, ZERO_CLOCK
        # a stamp rclpy / rclcpp cannot turn into a time (negative, nanosec >= 1e9) would reach
        # every consumer of the answer: refuse the request instead
        return stamp, stamp_error(stamp.sec, stamp.nanosec)

    def _answer(self, request: str, stamp, solve: Callable[[], Result]) -> Result:
        """Run one request and publish its answer (Outputs.answer: on success joint_states,
        the subscribed points and an OK status; on failure only an ERROR status). Never
        raises."""
        try:
            stamp, bad_stamp = self._request_stamp(stamp)
            if bad_stamp:
                result = Result(False, bad_stamp)
            else:
                try:
                    result = solve()
                except CommandError as exc:
                    result = Result(False, str(exc))
            self.outputs.answer(result, stamp, request)
            return result
        except Exception as exc:  # a bug must not take the node down: answer and keep going
            self.get_logger().error(
                f'internal error on {request}: {exc!r}\n' + traceback.format_exc()
            )
            self.outputs.internal_error(f'internal error: {exc!r}', request)
            return Result(False, f'internal error: {exc!r}')

    def _on_command(self, msg):
        self._answer(
            'command',
            msg.header.stamp,
            lambda: self.engine.command(
                joint_state_to_command(msg, self.max_names), joint_state_rates(msg)
            ),
        )

    def _on_target(self, raw: bytes):
        self._on_raw_target('target', raw, False)

    def _on_target_any_mode(self, raw: bytes):
        """~/target that may change the assembly mode (explicitly asked for)."""
        self._on_raw_target('target_any_mode', raw, True)

    def _on_raw_target(self, request: str, raw: bytes, any_mode: bool) -> None:
        peek = joint_state_peek(raw)
        if peek is not None and peek[2] > self.max_names:
            sec, nanosec, count = peek
            why = request_shape_error(range(count), count, self.max_names)
            self._answer(request, Time(sec=sec, nanosec=nanosec), lambda: Result(False, why))
            return
        try:
            msg = deserialize_message(raw, JointState)
        except Exception as exc:  # noqa: BLE001 - rmw already checked it; answer, never raise
            bad = f'not a JointState: {exc}'
            self._answer(request, Time(), lambda: Result(False, bad))
            return
        self._answer(
            request,
            msg.header.stamp,
            lambda: self.engine.target(
                joint_state_to_command(msg, self.max_names), allow_mode_change=any_mode
            ),
        )

    def _on_target_pose(self, link: str, msg):
        def solve():
            foreign = frame_error(f'target pose of {link!r}', msg.header.frame_id, self.frame_id)
            if foreign:
                return Result(False, foreign)
            x, y, yaw = pose_to_xy_yaw(msg, link)
            return self.engine.target(pose_target(self.mech, link, (x, y), yaw))

        self._answer(f'target_pose/{link}', msg.header.stamp, solve)

    def _on_trajectory(self, msg):
        """~/trajectory: every point solved, answered on ~/solved_trajectory and one status."""
        self._answer_trajectory(
            'trajectory', msg.header.stamp, lambda: answer_trajectory_msg(self.engine, msg)
        )

    def _on_target_path(self, point: str, msg):
        """~/target_path/<point>: the point's successive positions as one trajectory."""
        self._answer_trajectory(
            f'target_path/{point}',
            msg.header.stamp,
            lambda: answer_path_msg(self.engine, point, msg, self.frame_id),
        )

    def _answer_trajectory(self, request: str, stamp, solve) -> None:
        """_answer for a trajectory or path: the same stamp rules, one status. Never raises."""
        try:
            stamp, bad_stamp = self._request_stamp(stamp)
            times: list[int] = []
            if bad_stamp:
                answer = TrajectoryAnswer(False, bad_stamp)
            else:
                try:
                    answer, times = solve()
                except CommandError as exc:
                    answer = TrajectoryAnswer(False, str(exc))
            self.outputs.answer_trajectory(answer, stamp, request, times)
        except Exception as exc:  # a bug must not take the node down: answer and keep going
            self.get_logger().error(
                f'internal error on {request}: {exc!r}\n' + traceback.format_exc()
            )
            self.outputs.internal_error(f'internal error: {exc!r}', request)

    def _on_target_point(self, point: str, msg):

        def solve():
            foreign = frame_error(f'target point {point!r}', msg.header.frame_id, self.frame_id)
            if foreign:
                return Result(False, foreign)
            return self.engine.target_point(point, point_stamped_to_xy(msg, point))

        self._answer(f'target_point/{point}', msg.header.stamp, solve)

    # -- demo sweep --------------------------------------------------------------------------------
    def _check_demo_possible(self) -> None:
        if not self.mech.actuators:
            fail_setting(
                'demo_sweep',
                f'scene {self.mech.name!r} has no actuator to sweep (a structure: 0 DOF)',
                True,
            )

    def _start_demo(self):
        first = next(iter(self.mech.actuators))
        start = self.engine.last.inputs[first] if self.engine.last else 0.0
        self._demo = DemoSweep(self.mech, first, start)
        self._demo_failures = 0
        self._demo_timer = self.create_timer(1.0 / self.config.demo_rate, self._on_demo)
        self.get_logger().info(f'demo sweep of {first!r} at {self.config.demo_rate:g} Hz')

    def _stop_demo(self):
        if self._demo_timer is not None:
            self.destroy_timer(self._demo_timer)
            self._demo_timer = None

    def _on_demo(self):
        demo = self._demo
        last = self.engine.last
        values = dict(last.inputs) if last else {a: 0.0 for a in self.mech.actuators}
        values[demo.name] = demo.next()
        result = self._answer('demo', Time(), lambda: self.engine.command(values))
        if result.success:
            self._demo_failures = 0
            self.get_logger().info(
                format_joints(result, self.mech.joint_names, list(self.mech.actuators)),
                throttle_duration_sec=0.5,
            )
        else:
            self._demo_failures += 1
            demo.bounce(values[demo.name])
            if self._demo_failures >= 3:
                self.get_logger().error(
                    f'demo sweep stopped: {result.reason} (demo_sweep is '
                    'now false; set it to true to restart)'
                )
                self._stop_demo()
                # the parameter says what runs: setting it true again restarts the sweep
                self.set_parameters([Parameter('demo_sweep', value=False)])


#: When the node looks at the graph for another node of its name (s after start-up, times)
CLASH_CHECK_S = 1.0
CLASH_CHECKS = 10

#: How long the spin loop may block before it looks at the stop flag (s): the latency of a
#: shutdown on SIGINT / SIGTERM, not of any message.
STOP_POLL_S = 0.1


class _StopOnSignal:
    """SIGINT and SIGTERM (what systemd, docker and ros2 launch send) both ask the spin loop to
    stop. rclpy's own handlers shut the context down from under a running callback (an RCLError
    traceback, or a spin that never wakes); here the handler only sets a flag, the callback in
    progress finishes, and main() destroys the node and shuts rclpy down itself."""

    def __init__(self) -> None:
        self.requested: int | None = None

    def install(self) -> None:
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self._on_signal)

    def _on_signal(self, signum: int, _frame: Any) -> None:
        if self.requested is None:
            self.requested = signum


def make_executor(node: LinkageNode) -> Executor:
    """The executor the ``executor`` parameter names. EventsExecutor (rclpy.experimental)
    takes the next ready callback from a C++ event queue instead of rebuilding a wait set of
    every subscription, timer and service on each wakeup, which is most of the node's cost per
    command; where rclpy lacks it, SingleThreadedExecutor with a warning."""
    if node.config.executor == 'events':
        try:
            from rclpy.experimental import EventsExecutor
        except ImportError as exc:
            node.get_logger().warning(
                f'executor events: not in this rclpy ({exc}); using single_threaded'
            )
        else:
            return EventsExecutor()
    return SingleThreadedExecutor()


def main(args: Sequence[str] | None = None) -> int:
    """Entry point of ``linkage_node``. Returns the process exit code (0 clean, also on SIGINT
    and SIGTERM; 1 bad configuration)."""
    stop = _StopOnSignal()
    stop.install()  # before rclpy.init: a signal during start-up is a clean stop too
    try:
        rclpy.init(
            args=None if args is None else list(args),
            signal_handler_options=SignalHandlerOptions.NO,
        )
    except Exception as exc:  # malformed --ros-args or parameter file: rcl says why
        print(f'[FATAL] [{NODE_NAME}]: cannot start: {exc}', file=sys.stderr)
        return 1
    node = None
    executor = None
    try:
        node = LinkageNode()
        executor = make_executor(node)
        executor.add_node(node)
        # start-up objects (modules, the scene, compiled plans) live as long as the process:
        # move them out of the collector's sight so a full collection does not stall a command
        gc.freeze()
        while stop.requested is None and rclpy.ok():
            executor.spin_once(timeout_sec=STOP_POLL_S)
    except (ConfigError, SceneError) as exc:
        rclpy.logging.get_logger(NODE_NAME).fatal(f'cannot start: {exc}')
        return 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        # a second signal while shutting down changes nothing
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        if executor is not None:
            executor.shutdown(timeout_sec=1.0)
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
