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
import signal
import sys
import traceback
from collections.abc import Sequence
from typing import Any

import rclpy
from geometry_msgs.msg import PointStamped, PoseStamped
from nav_msgs.msg import Path
from rcl_interfaces.msg import SetParametersResult
from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory

from .core.errors import SceneError
from .core.model import Mechanism, Scene
from .core.solver import Result
from .engine import Engine
from .heap import keep_large_buffers
from .node_demo import DemoRunner
from .node_requests import Requests
from .node_runtime import (
    NameClashCheck,
    StopOnSignal,
    declare_parameters,
    log_mechanism,
    make_executor,
    one_line,
    spin_until_stopped,
)
from .params import (
    DEMO_RATE_MAX,
    DEMO_RATE_MIN,
    NODE_NAME,
    PARAMETERS,
    QUEUE_DEPTH_MAX,
    NodeConfig,
    check_demo_rate,
    load_engine,
    make_config,
)
from .plan_cdr import joint_state_bytes_bound
from .plan_requests import PlanRequests
from .plan_worker import CommandClock
from .publishing import Channels, Outputs, Waiting, latched_qos, topic_qos
from .request_checks import max_request_names
from .setting_checks import ConfigError, fail_setting

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

    def destroy_node(self) -> None:
        plans = getattr(self, 'plans', None)
        if plans is not None:  # the worker ends first: it hands its answers to this node
            plans.destroy()
        super().destroy_node()

    # -- set-up ----------------------------------------------------------------------------------
    def _setup(self):
        self.config = cfg = make_config(declare_parameters(self))
        # the mechanism and what serves it (_serve sets them; None while waiting for a robot
        # description on robot_description_topic)
        self.scene: Scene | None = None
        self.engine: Engine | None = None
        self.mech: Mechanism | None = None
        self.outputs: Outputs | None = None
        self.frame_id = cfg.frame_id
        self.max_names = 0
        self.max_request_bytes = 0
        self._mech_subs: list[Any] = []  # per point / per link: destroyed with the mechanism
        self._description = ''  # the robot description text served (from the topic)
        self.waiting: Waiting | None = None
        #: state completion: inputs read from joint_states_in and commanded; mimic followers
        #: among the actuated joints (left out of joint_states when the hardware sends them)
        self.state_inputs: frozenset[str] = frozenset()
        self.state_followers: frozenset[str] = frozenset()
        self.demo = DemoRunner(self)
        # when a request was last answered: the plan worker paces itself while they come
        commands = CommandClock()
        self.requests = Requests(self, commands)
        # the publishers every mechanism shares (and the waiting state answers on)
        self.channels = Channels(self, cfg)
        # ~/command and ~/target keep rclpy's default QoS-event warnings; the others carry none
        # (see Outputs: each handler costs every executor wakeup)
        qos = topic_qos(cfg.queue_depth)
        quiet_sub = SubscriptionEventCallbacks(use_default_callbacks=False)
        # commands arrive serialised: their fields are read off the bytes (command_cdr.py), not
        # built into a Python message first
        self.create_subscription(
            JointState, '~/command', self.requests.on_raw_command, qos, raw=True
        )
        # targets arrive serialised: a request with more names than the scene has is refused
        # from its first bytes, before rclpy would build 10^5 Python strings for it
        self.create_subscription(JointState, '~/target', self.requests.on_target, qos, raw=True)
        self.create_subscription(
            JointState,
            '~/target_any_mode',
            self.requests.on_target_any_mode,
            qos,
            event_callbacks=quiet_sub,
            raw=True,
        )
        # plans (trajectories, paths): many requests answered as one, solved beside the
        # commands by a worker (plan_requests.py); taken serialised, refused by size first
        self.plans = PlanRequests(self, commands)
        self.create_subscription(
            JointTrajectory,
            '~/trajectory',
            self.plans.on_trajectory,
            qos,
            event_callbacks=quiet_sub,
            raw=True,
        )
        if cfg.joint_states_in:
            own = self.resolve_topic_name('joint_states')
            if cfg.publish_inputs and self.resolve_topic_name(cfg.joint_states_in) == own:
                fail_setting(
                    'publish_inputs',
                    f"joint_states_in {cfg.joint_states_in!r} is the node's own joint_states "
                    f'({own}): with the inputs published there the node would command itself; '
                    'give the hardware stream another topic',
                    True,
                )
            self.create_subscription(
                JointState, cfg.joint_states_in, self.requests.on_joint_states_in, qos
            )
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
            self.waiting = Waiting(self, self.channels, topic)
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
        self._clash_check = NameClashCheck(self)

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
                self,
                engine,
                cfg,
                frame_id,
                self.channels,
                self.source_text(),
                clear_markers=replacing,
            )
            self._subscribe_mechanism(mech, subs)
        except BaseException:
            for sub in subs:
                self.destroy_subscription(sub)
            if outputs is not None:
                outputs.destroy()
            raise
        # the new one is complete: the old one goes
        self.demo.stop()
        for sub in self._mech_subs:
            self.destroy_subscription(sub)
        if self.outputs is not None:
            self.outputs.destroy()
        if self.waiting is not None:
            self.waiting.destroy()
            self.waiting = None
        self.scene, self.engine, self.mech, self.outputs = scene, engine, mech, outputs
        self.plans.serve(engine)  # the plan worker builds its engine now, not beside commands
        self._mech_subs = subs
        self.frame_id = frame_id
        self.max_names = max_request_names(mech)  # a longer request is refused at once
        self.max_request_bytes = joint_state_bytes_bound(mech)  # and a larger ~/target
        self.state_inputs = frozenset(mech.commanded_input_names)
        self.state_followers = frozenset(mech.output_input_names) - self.state_inputs
        if cfg.joint_states_in and not cfg.publish_inputs:
            # the hardware publishes the inputs: joint_states carries the rest
            outputs.set_omit_joints(self.state_inputs)
        log_mechanism(self, scene, replacing)
        if cfg.demo_sweep:
            if mech.actuators:
                self.demo.start()
            else:  # a structure from robot_description_topic
                self.get_logger().error(
                    f'demo sweep stopped: scene {mech.name!r} has no actuator to sweep (a '
                    'structure: 0 DOF); demo_sweep is now false'
                )
                self.set_parameters([Parameter('demo_sweep', value=False)])

    def source_text(self) -> str:
        """Where the served mechanism comes from, for logs: the description topic (resolved)
        or the scene's file or parameter."""
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
        # a path is a plan: taken serialised (plan_requests.py)
        topics = (
            (PointStamped, 'target_point', points, self.requests.on_target_point, False),
            (PoseStamped, 'target_pose', links, self.requests.on_target_pose, False),
            (Path, 'target_path', points, self.plans.on_path, True),
        )
        for msg_type, topic, names, callback, raw in topics:
            for name in names:
                subs.append(
                    self.create_subscription(
                        msg_type,
                        f'~/{topic}/{name}',
                        functools.partial(callback, name),
                        qos,
                        event_callbacks=quiet_sub,
                        raw=raw,
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
            assert self.waiting is not None
            log.error(f'robot description refused: {reason}; still waiting for one')
            self.waiting.refused_description = reason
            self.waiting.answer('robot_description')
            self.waiting.diagnose()
            return
        assert self.mech is not None
        why = f'robot description refused: {reason}'
        log.error(f'{why}; still serving {self.mech.name!r}')
        self.outputs.description_error = why
        self.outputs.answer(
            Result(False, why), self.get_clock().now().to_msg(), 'robot_description'
        )
        self.outputs.diagnose()

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
        self.demo.stop()
        self.config = cfg
        if cfg.demo_sweep and self.mech is not None:  # else it starts when a mechanism arrives
            self.demo.start()

    # -- demo sweep --------------------------------------------------------------------------------
    def _check_demo_possible(self, mech: Mechanism | None = None) -> None:
        mech = mech or self.mech
        if mech is not None and not mech.actuators:  # none yet: starts on arrival
            fail_setting(
                'demo_sweep',
                f'scene {mech.name!r} from {self.source_text()} has no actuator to sweep (a '
                'structure: 0 DOF)',
                True,
            )


def remapped_node_name(argv: Sequence[str]) -> str:
    """The node's logger name as ``-r __node:=NAME`` (or ``__name``, or
    ``linkage_node:__node:=``) and ``-r __ns:=/NS`` among the ROS arguments make it (rclpy's
    ``ns.name``: 'arm.left'), else NODE_NAME: the name a start-up refusal is logged under, as
    the node's other lines are (it has no node to ask)."""
    name, ns, ros, i = NODE_NAME, '', False, 0
    while i < len(argv):
        a = argv[i]
        if a == '--ros-args':
            ros = True
        elif a == '--':
            ros = False
        elif ros and a in ('-r', '--remap') and i + 1 < len(argv):
            rule = argv[i + 1]
            target, _, value = rule.partition(':=')
            mine = ':' not in target or target.split(':')[0] == NODE_NAME
            if target.split(':')[-1] in ('__node', '__name') and value and mine:
                name = value
            elif target.split(':')[-1] == '__ns' and mine:
                ns = value.strip('/').replace('/', '.')
            i += 1
        i += 1
    return f'{ns}.{name}' if ns else name


def main(args: Sequence[str] | None = None) -> int:
    """Entry point of ``linkage_node``. Returns the process exit code (0 clean, also on SIGINT
    and SIGTERM; 1 bad configuration)."""
    stop = StopOnSignal()
    stop.install()  # before rclpy.init: a signal during start-up is a clean stop too
    keep_large_buffers()  # a 2 MB request must not fault its buffers in anew (heap.py)
    try:
        rclpy.init(
            args=None if args is None else list(args),
            signal_handler_options=SignalHandlerOptions.NO,
        )
    except Exception as exc:  # malformed --ros-args or parameter file: rcl says why
        hint = ''
        if "Couldn't parse parameter override rule" in str(exc) and 'No value' in str(exc):
            # (-p branch:=- : YAML reads '-' as nothing; TOPICS.md documents the quoting)
            hint = (
                ' (a value YAML reads as nothing, such as -: quote it for the parameter '
                'parser, -p "branch:=\'-\'")'
            )
        name = remapped_node_name(sys.argv if args is None else list(args))
        print(f'[FATAL] [{name}]: cannot start: {exc}{hint}', file=sys.stderr)
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
        spin_until_stopped(executor, stop)
    except (ConfigError, SceneError) as exc:
        name = remapped_node_name(sys.argv if args is None else list(args))
        rclpy.logging.get_logger(name).fatal(f'cannot start: {exc}')
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
