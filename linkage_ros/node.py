"""``linkage_node``: planar-mechanism kinematics served over ROS 2 topics.

A thin shell around the core (see docs/TOPICS.md for the full interface):

* ``~/command``  sensor_msgs/JointState (actuator names, rad or m)   -> forward kinematics
* ``~/target``   sensor_msgs/JointState (joint/link/actuator names)  -> inverse kinematics
* ``~/target_point/<point>`` geometry_msgs/PointStamped              -> inverse kinematics
* publishes ``joint_states``, ``~/points/<name>``, ``~/markers`` and one ``~/status`` per request.

The mechanism comes from a scene file, a robot description (a URDF/SDF path, the
``robot_description`` parameter, or ``robot_description_topic``, where a later description
replaces it whole), and with ``joint_states_in`` the node completes a hardware JointState: the
inputs it reads command it, joint_states carries the passive joints.

Each callback is message -> plain data (conversions) -> core Solver -> message. A bad request is
answered by exactly one ERROR status and changes nothing; the node keeps the last good state.
"""

from __future__ import annotations

import dataclasses
import functools
import gc
import math
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
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from .conversions import (
    format_joints,
    is_zero_stamp,
    joint_state_peek,
    joint_state_pick,
    joint_state_rates,
    joint_state_to_command,
    point_stamped_to_xy,
    pose_to_xy_yaw,
)
from .core.errors import CommandError, SceneError
from .core.model import Mechanism, Scene
from .core.solver import Result
from .core.solver.modes import reference_toggle_warnings
from .demo import DemoSweep
from .engine import Engine, max_request_names, name_count_error
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
from .publishing import Channels, Outputs, Waiting, latched_qos, topic_qos
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
            # a double takes a whole number too (ROS users write `-p publish_rate:=0`): typed
            # dynamically, then checked to be a number and converted (make_config)
            number = isinstance(p.default, float)
            desc = ParameterDescriptor(
                description=p.description,
                read_only=p.read_only,
                additional_constraints=p.constraints,
                dynamic_typing=number,
            )
            default = Parameter.Type.STRING_ARRAY if p.default == 'string_array' else p.default
            try:
                param = self.declare_parameter(p.name, default, desc)
            except InvalidParameterTypeException as exc:
                kind = (
                    type(p.default).__name__
                    if p.default != 'string_array'
                    else f'list of strings (write {p.name}:=[a, b])'
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
            value = param.value
            if number:
                if isinstance(value, bool) or not isinstance(value, int | float):
                    raise ConfigError(
                        f'parameter {p.name!r}: must be a number (a double or a whole number; '
                        f'got {value!r})'
                    )
                value = float(value)
            values[p.name] = value
        return values

    def _setup(self):
        self.config = cfg = make_config(self._declare_parameters())
        # the mechanism and what serves it (_serve sets them; None while waiting for a robot
        # description on robot_description_topic)
        self.scene: Scene | None = None
        self.engine: Engine | None = None
        self.mech: Mechanism | None = None
        self.outputs: Outputs | None = None
        self.frame_id = cfg.frame_id
        self.max_names = 0
        self._mech_subs: list[Any] = []  # per point / per link: destroyed with the mechanism
        self._description = ''  # the robot description text served (from the topic)
        self._waiting: Waiting | None = None
        #: state completion: inputs read from joint_states_in and commanded; mimic followers
        #: among the actuated joints (left out of joint_states when the hardware sends them)
        self._state_inputs: frozenset[str] = frozenset()
        self._state_followers: frozenset[str] = frozenset()
        self._demo_timer = None
        self._demo: DemoSweep | None = None
        self._demo_failures = 0
        # the publishers every mechanism shares (and the waiting state answers on)
        self.channels = Channels(self, cfg)
        # ~/command and ~/target keep rclpy's default QoS-event warnings; the others carry none
        # (see Outputs: each handler costs every executor wakeup)
        qos = topic_qos(cfg.queue_depth)
        quiet_sub = SubscriptionEventCallbacks(use_default_callbacks=False)
        self.create_subscription(JointState, '~/command', self._on_command, qos)
        # targets arrive serialised: a request with more names than the scene has is refused
        # from its first bytes, before rclpy would build 10^5 Python strings for it
        self.create_subscription(JointState, '~/target', self._on_target, qos, raw=True)
        self.create_subscription(
            JointState,
            '~/target_any_mode',
            self._on_target_any_mode,
            qos,
            event_callbacks=quiet_sub,
            raw=True,
        )
        # trajectories: many requests answered as one (trajectory.py)
        self.create_subscription(
            JointTrajectory, '~/trajectory', self._on_trajectory, qos, event_callbacks=quiet_sub
        )
        if cfg.joint_states_in:
            self.create_subscription(JointState, cfg.joint_states_in, self._on_joint_states_in, qos)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        log = self.get_logger()
        # rclpy keeps an override this node never declares without a word: a misspelt name
        # would silently leave its parameter at the default
        overrides = getattr(self, '_parameter_overrides', None) or {}
        ignored = sorted(n for n in overrides if not self.has_parameter(n))
        if ignored:
            log.warning(
                f'ignoring parameter(s) this node does not have: {ignored} (its '
                f'parameters: {", ".join(p.name for p in PARAMETERS)})'
            )
        if cfg.robot_description_topic:
            topic = self.resolve_topic_name(cfg.robot_description_topic)
            self._waiting = Waiting(self, self.channels, topic)
            self.create_subscription(
                String,
                cfg.robot_description_topic,
                self._on_robot_description,
                latched_qos(),
                event_callbacks=quiet_sub,
            )
            # the last start-up line while there is no mechanism yet
            log.info(
                f'waiting for a robot description on {topic} (std_msgs/String, reliable, '
                'transient local): every request is refused until one arrives'
            )
        else:
            scene, engine = load_engine(cfg)
            self._serve(scene, engine)
        # another node of this name in this namespace mixes its answers, status and parameter
        # services with ours: look at the graph once discovery has had time to see it
        self._clash_checks = 0
        self._clash_timer = self.create_timer(CLASH_CHECK_S, self._check_name_clash)

    # -- the mechanism -----------------------------------------------------------------------------
    def _serve(self, scene: Scene, engine: Engine) -> None:
        """Serve ``scene``: its Outputs and per-point / per-link subscriptions, its start-up log
        lines, the demo if it is on. A mechanism served before is replaced whole (its outputs
        and subscriptions destroyed); if building the new one fails, the old one stays and the
        exception goes on."""
        cfg = self.config
        mech = scene.mechanism
        frame_id = cfg.frame_id or mech.frame_id
        replacing = self.mech is not None
        if cfg.demo_sweep and not replacing and not cfg.robot_description_topic:
            self._check_demo_possible(mech)  # start-up stops here, before any other line
        subs: list[Any] = []
        outputs = None
        try:
            outputs = Outputs(
                self, engine, cfg, frame_id, self.channels, self._source(), clear_markers=replacing
            )
            self._subscribe_mechanism(mech, subs)
        except BaseException:
            for sub in subs:
                self.destroy_subscription(sub)
            if outputs is not None:
                outputs.destroy()
            raise
        # the new one is complete: the old one goes
        self._stop_demo()
        for sub in self._mech_subs:
            self.destroy_subscription(sub)
        if self.outputs is not None:
            self.outputs.destroy()
        if self._waiting is not None:
            self._waiting.destroy()
            self._waiting = None
        self.scene, self.engine, self.mech, self.outputs = scene, engine, mech, outputs
        self._mech_subs = subs
        self.frame_id = frame_id
        self.max_names = max_request_names(mech)  # a longer request is refused at once
        self._state_inputs = frozenset(mech.commanded_input_names)
        self._state_followers = frozenset(mech.output_input_names) - self._state_inputs
        if cfg.joint_states_in:  # the hardware publishes the inputs: joint_states carries the rest
            outputs.set_omit_joints(self._state_inputs)
        self._log_mechanism(scene, replacing)
        if cfg.demo_sweep:
            if mech.actuators:
                self._start_demo()
            else:  # a structure from robot_description_topic
                self.get_logger().error(
                    f'demo sweep stopped: scene {mech.name!r} has no actuator to sweep (a '
                    'structure: 0 DOF); demo_sweep is now false'
                )
                self.set_parameters([Parameter('demo_sweep', value=False)])

    def _source(self) -> str:
        cfg = self.config
        if cfg.robot_description_topic:
            return self.resolve_topic_name(cfg.robot_description_topic)
        return cfg.source

    def _subscribe_mechanism(self, mech: Mechanism, subs: list[Any]) -> None:
        """The per-point and per-link request topics of ``mech``, appended to ``subs`` as they
        are made (so a failure part-way can destroy those made)."""
        qos = topic_qos(self.config.queue_depth)
        quiet_sub = SubscriptionEventCallbacks(use_default_callbacks=False)
        ground = set(mech.links[mech.ground].points)
        points = [p for p in mech.points if p not in ground]
        links = [l for l in mech.links if l != mech.ground]
        # a link's pose (its first point and its angle) from a PoseStamped, e.g. a TF pose
        topics = (
            (PointStamped, 'target_point', points, self._on_target_point),
            (PoseStamped, 'target_pose', links, self._on_target_pose),
            (Path, 'target_path', points, self._on_target_path),
        )
        for msg_type, topic, names, callback in topics:
            for name in names:
                subs.append(
                    self.create_subscription(
                        msg_type,
                        f'~/{topic}/{name}',
                        functools.partial(callback, name),
                        qos,
                        event_callbacks=quiet_sub,
                    )
                )

    def _log_mechanism(self, scene: Scene, replacing: bool) -> None:
        """The start-up lines of a mechanism (again when a robot description replaces it)."""
        mech, engine, cfg, log = scene.mechanism, self.engine, self.config, self.get_logger()
        assert engine is not None and self.outputs is not None
        log.info(
            ('robot description replaced: ' if replacing else '')
            + f'scene {mech.name!r} from {self._source()}: {mech.dof} DOF, '
            f'actuators {list(mech.actuators)}, joints {mech.output_joint_names}, outputs '
            f'{list(mech.outputs)}, frame {self.frame_id!r}, solver '
            f'{engine.forward.mode}, branch {cfg.branch}'
            + (
                ', dimensions ' + ', '.join(f'{k}={v:.12g}' for k, v in mech.stated.items())
                if mech.stated
                else ''
            )
        )
        for note in scene.notes:
            log.info(f'scene {mech.name!r}: {note}')
        for warning in scene.warnings:  # likely degrees read as radians (core.units)
            log.warning(f'scene {mech.name!r}: {warning}')
        omit = self.outputs.omit_joints
        published = [cfg.prefix + j for j in mech.output_joint_names if j not in omit]
        log.info(
            f'joint_states names: {published}'
            + (
                f' (leaving out {sorted(omit & set(mech.output_joint_names))}: '
                f'{self.resolve_topic_name(cfg.joint_states_in)} gives them)'
                if cfg.joint_states_in
                else ''
            )
        )
        for warning in reference_toggle_warnings(engine.forward):
            log.warning(f'scene {mech.name!r}: {warning}')
        if mech.dof > 2 and not cfg.target_point_hold:
            log.warning(
                f'{mech.dof}-DOF scene: ~/target_point/<point> needs target_point_hold '
                f'naming {mech.dof - 2} held value(s)'
            )
        commands = sorted(self._state_inputs, key=mech.output_input_names.index)
        # the last start-up line: whoever waits for it has every start-up warning already
        log.info(
            f'listening on {self.resolve_topic_name("~/command")} (sensor_msgs/JointState '
            f'{commands}), publishing {self.resolve_topic_name("joint_states")} '
            f'(reliable, keep last {cfg.output_depth}; commands keep last '
            f'{cfg.queue_depth})'
            + (
                f'; state completion from {self.resolve_topic_name(cfg.joint_states_in)}'
                if cfg.joint_states_in
                else ''
            )
        )

    def _on_robot_description(self, msg: String) -> None:
        """A robot description on robot_description_topic: the first one starts serving, a
        later one replaces the mechanism; one that does not load is refused (the mechanism
        served, if any, keeps running). Never raises."""
        text = msg.data
        if self.outputs is not None and text == self._description:
            # the one served, again (after a refused one, the robot is back to it)
            self.get_logger().info('robot description unchanged: the mechanism stays as it is')
            self.outputs.description_error = ''
            return
        try:
            if not text.strip():
                raise SceneError('the robot description is empty')
            scene, engine = load_engine(self.config, text)
            self._serve(scene, engine)
        except (SceneError, ConfigError) as exc:
            self._refuse_description(str(exc))
            return
        except Exception as exc:  # a bug must not take the node down: refuse and keep going
            self.get_logger().error(
                f'internal error on a robot description: {exc!r}\n' + traceback.format_exc()
            )
            self._refuse_description(f'internal error: {exc!r}')
            return
        self._description = text

    def _refuse_description(self, reason: str) -> None:
        """Refuse a robot description: logged, one ERROR status, /diagnostics ERROR at once.
        Never raises."""
        try:
            self._report_refused(one_line(reason))
        except Exception as exc:  # noqa: BLE001 - never raise from a callback
            self.get_logger().error(f'robot description refused: {reason}; and then: {exc!r}')

    def _report_refused(self, reason: str) -> None:
        log = self.get_logger()
        if self.outputs is None:
            assert self._waiting is not None
            log.error(f'robot description refused: {reason}; still waiting for one')
            self._waiting.refused_description = reason
            self._waiting.answer('robot_description')
            self._waiting.diagnose()
            return
        assert self.mech is not None
        why = f'robot description refused: {reason}'
        log.error(f'{why}; still serving {self.mech.name!r}')
        self.outputs.description_error = why
        self.outputs.answer(
            Result(False, why), self.get_clock().now().to_msg(), 'robot_description'
        )
        self.outputs.diagnose()

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
                if p.name == 'use_sim_time' and p.value != self.get_parameter(p.name).value:
                    # the node's timers (republication, markers, /diagnostics, the demo) run
                    # on its clock: switched at runtime they would stop until /clock arrives
                    fail_setting(
                        'use_sim_time',
                        'can only be set at start-up (--ros-args -p use_sim_time:=true): '
                        "switched at runtime, the node's timers would stop without a word",
                        p.value,
                    )
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
        if cfg.demo_sweep and self.mech is not None:  # else it starts when a mechanism arrives
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
        if self.outputs is None:  # no robot description yet
            return self._refuse_waiting(request)
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

    def _refuse_waiting(self, request: str) -> Result:
        """Answer a request that came before any robot description: an ERROR status saying
        the node waits for one. Never raises."""
        assert self._waiting is not None
        try:
            self._waiting.answer(request)
        except Exception as exc:  # noqa: BLE001 - never raise from a callback
            self.get_logger().error(f'internal error on {request}: {exc!r}')
        return Result(False, self._waiting.reason())

    def _on_command(self, msg):
        self._answer(
            'command',
            msg.header.stamp,
            lambda: self._served_engine().command(
                joint_state_to_command(msg, self.max_names), joint_state_rates(msg)
            ),
        )

    def _served_engine(self) -> Engine:
        """The engine being served: request callbacks exist only while one is (and _answer
        refuses while waiting for a robot description)."""
        assert self.engine is not None
        return self.engine

    def _served_mech(self) -> Mechanism:
        assert self.mech is not None
        return self.mech

    def _on_target(self, raw: bytes):
        self._on_raw_target('target', raw, False)

    def _on_target_any_mode(self, raw: bytes):
        """~/target that may change the assembly mode (explicitly asked for)."""
        self._on_raw_target('target_any_mode', raw, True)

    def _on_raw_target(self, request: str, raw: bytes, any_mode: bool) -> None:
        if self.outputs is None:  # no robot description yet
            self._refuse_waiting(request)
            return
        peek = joint_state_peek(raw)
        if peek is not None and peek[2] > self.max_names:
            sec, nanosec, count = peek
            why = name_count_error(count, self.max_names)
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
            lambda: self._served_engine().target(
                joint_state_to_command(msg, self.max_names), allow_mode_change=any_mode
            ),
        )

    def _on_target_pose(self, link: str, msg):
        def solve():
            foreign = frame_error(f'target pose of {link!r}', msg.header.frame_id, self.frame_id)
            if foreign:
                return Result(False, foreign)
            x, y, yaw = pose_to_xy_yaw(msg, link)
            mech = self._served_mech()
            return self._served_engine().target(pose_target(mech, link, (x, y), yaw))

        self._answer(f'target_pose/{link}', msg.header.stamp, solve)

    def _on_trajectory(self, msg):
        """~/trajectory: every point solved, answered on ~/solved_trajectory and one status."""
        self._answer_trajectory(
            'trajectory',
            msg.header.stamp,
            lambda: answer_trajectory_msg(self._served_engine(), msg, self.frame_id),
        )

    def _on_target_path(self, point: str, msg):
        """~/target_path/<point>: the point's successive positions as one trajectory."""
        self._answer_trajectory(
            f'target_path/{point}',
            msg.header.stamp,
            lambda: answer_path_msg(self._served_engine(), point, msg, self.frame_id),
        )

    def _answer_trajectory(self, request: str, stamp, solve) -> None:
        """_answer for a trajectory or path: the same stamp rules, one status. Never raises."""
        if self.outputs is None:  # no robot description yet
            self._refuse_waiting(request)
            return
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
            xy = point_stamped_to_xy(msg, point, self._served_mech())
            return self._served_engine().target_point(point, xy)

        self._answer(f'target_point/{point}', msg.header.stamp, solve)

    def _on_joint_states_in(self, msg: JointState) -> None:
        """State completion: the mechanism's inputs in a hardware JointState command it; the
        answer's joint_states leave them out. A message carrying none of them (the node's own
        joint_states among others) is ignored, and so is every message before a robot
        description arrives (the inputs are not known yet). Never raises."""
        if self.outputs is None:
            return
        try:
            values, rates = joint_state_pick(msg, self._state_inputs | self._state_followers)
        except CommandError as exc:
            bad = str(exc)
            self._answer('joint_states_in', msg.header.stamp, lambda: Result(False, bad))
            return
        except Exception as exc:  # noqa: BLE001 - a broken message must not raise here
            bad = f'not a JointState: {exc!r}'
            self._answer('joint_states_in', msg.header.stamp, lambda: Result(False, bad))
            return
        command = {n: v for n, v in values.items() if n in self._state_inputs}
        if not command:
            # no input: not the hardware's (the node's own joint_states carries a follower)
            return
        followers = self._state_followers.intersection(values)
        if followers - self.outputs.omit_joints:  # the hardware publishes a mimic follower too
            self.outputs.set_omit_joints(self.outputs.omit_joints | followers)
        # joint_state_broadcaster fills a joint without a velocity interface with NaN: such
        # rates are no rates, positions alone command
        if rates is not None and all(math.isfinite(rates[n]) for n in command):
            command_rates: dict[str, float] | None = {n: rates[n] for n in command}
        else:
            command_rates = None
        engine = self.engine
        assert engine is not None
        self._answer(
            'joint_states_in', msg.header.stamp, lambda: engine.command(command, command_rates)
        )

    # -- demo sweep --------------------------------------------------------------------------------
    def _check_demo_possible(self, mech: Mechanism | None = None) -> None:
        mech = mech or self.mech
        if mech is not None and not mech.actuators:  # none yet: starts on arrival
            fail_setting(
                'demo_sweep',
                f'scene {mech.name!r} from {self._source()} has no actuator to sweep (a '
                'structure: 0 DOF)',
                True,
            )

    def _start_demo(self):
        mech, last = self._served_mech(), self._served_engine().last
        first = next(iter(mech.actuators))
        start = last.inputs[first] if last else 0.0
        self._demo = DemoSweep(mech, first, start)
        self._demo_failures = 0
        self._demo_timer = self.create_timer(1.0 / self.config.demo_rate, self._on_demo)
        self.get_logger().info(f'demo sweep of {first!r} at {self.config.demo_rate:g} Hz')

    def _stop_demo(self):
        if self._demo_timer is not None:
            self.destroy_timer(self._demo_timer)
            self._demo_timer = None

    def _on_demo(self):
        demo, engine, mech = self._demo, self._served_engine(), self._served_mech()
        assert demo is not None  # the timer runs only with a demo
        last = engine.last
        values = dict(last.inputs) if last else {a: 0.0 for a in mech.actuators}
        values[demo.name] = demo.next()
        result = self._answer('demo', Time(), lambda: engine.command(values))
        if result.success:
            self._demo_failures = 0
            self.get_logger().info(
                format_joints(result, mech.joint_names, list(mech.actuators)),
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


def one_line(text: str, limit: int = 400) -> str:
    """``text`` on one line (whitespace runs, line breaks too, become one space), cut to
    ``limit`` characters: a reason for a log line and a diagnostic message."""
    flat = ' '.join(text.split())
    return flat if len(flat) <= limit else flat[: limit - 3] + '...'


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
