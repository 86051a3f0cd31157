"""The node's process around it (ROS, not ROS-free): parameter declaration, the start-up log
lines, the executor the ``executor`` parameter names, and SIGINT / SIGTERM as a clean stop."""

from __future__ import annotations

import signal
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, ParameterType
from rclpy.exceptions import InvalidParameterTypeException, ParameterException
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.task import Future

from .core.model import Scene
from .core.reference_warnings import reference_pose_warnings
from .params import PARAMETERS, STRING_ARRAY
from .setting_checks import ConfigError


def declare_parameters(node: Node) -> dict[str, Any]:
    """Declare every node parameter (PARAMETERS) on ``node``, with its descriptor; their values,
    numbers as float; ConfigError for a value of the wrong type."""
    values = {}
    for p in PARAMETERS:
        # a double takes a whole number too (ROS users write `-p publish_rate:=0`): typed
        # dynamically, then checked to be a number and converted (make_config)
        number = isinstance(p.default, float)
        strings = p.default is STRING_ARRAY
        desc = ParameterDescriptor(
            description=p.description,
            # (a string array is made read-only once it holds its value: see below)
            read_only=p.read_only and not strings,
            additional_constraints=p.constraints,
            dynamic_typing=number,
        )
        default = Parameter.Type.STRING_ARRAY if strings else p.default
        try:
            param = node.declare_parameter(p.name, default, desc)
            if strings:
                param = _empty_string_array(node, param, desc, p.read_only)
        except InvalidParameterTypeException as exc:
            kind = (
                type(p.default).__name__
                if not strings
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


def _empty_string_array(
    node: Node, param: Parameter, desc: ParameterDescriptor, read_only: bool
) -> Parameter:
    """A string array parameter not given at start-up set to [] (rclpy takes an empty list
    for a byte array, so it is declared by its type and has no value: ``param get`` and ros2
    param then answer that it is not set, not its documented default []); made read-only
    after that where it is."""
    if param.type_ is Parameter.Type.NOT_SET:
        node.set_parameters([Parameter(param.name, Parameter.Type.STRING_ARRAY, [])])
    if read_only:  # (a new descriptor: rclpy keeps the one it was declared with)
        node.set_descriptor(
            param.name,
            ParameterDescriptor(
                description=desc.description,
                read_only=True,
                additional_constraints=desc.additional_constraints,
                type=ParameterType.PARAMETER_STRING_ARRAY,
            ),
        )
    return node.get_parameter(param.name)


def log_mechanism(node: Any, scene: Scene, replacing: bool) -> None:
    """The start-up lines of ``node``'s mechanism (again when a robot description replaces
    it); the last one says where it listens: whoever waits for it has every warning already."""
    mech, engine, cfg, log = scene.mechanism, node.engine, node.config, node.get_logger()
    assert engine is not None and node.outputs is not None
    log.info(
        ('robot description replaced: ' if replacing else '')
        + f'scene {mech.name!r} from {node.source_text()}: {mech.dof} DOF, '
        f'actuators {list(mech.actuators)}, joints {mech.output_joint_names}, outputs '
        f'{list(mech.outputs)}, frame {node.frame_id!r}, solver '
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
    omit = node.outputs.omit_joints
    published = [cfg.prefix + j for j in mech.output_joint_names if j not in omit]
    log.info(
        f'joint_states names: {published}'
        + (
            f' (leaving out {sorted(omit & set(mech.output_joint_names))}: '
            f'{node.resolve_topic_name(cfg.joint_states_in)} gives them)'
            if cfg.joint_states_in
            else ''
        )
    )
    for warning in reference_pose_warnings(engine.forward):  # every plan kind
        log.warning(f'scene {mech.name!r}: {warning}')
    if mech.dof > 2 and not cfg.target_point_hold:
        log.warning(
            f'{mech.dof}-DOF scene: ~/target_point/<point> needs target_point_hold '
            f'naming {mech.dof - 2} held value(s)'
        )
    commands = sorted(node.state_inputs, key=mech.output_input_names.index)
    # the last start-up line: whoever waits for it has every start-up warning already
    log.info(
        f'listening on {node.resolve_topic_name("~/command")} (sensor_msgs/JointState '
        f'{commands}), publishing {node.resolve_topic_name("joint_states")} '
        f'(reliable, keep last {cfg.output_depth}; commands keep last '
        f'{cfg.queue_depth})'
        + (
            f'; state completion from {node.resolve_topic_name(cfg.joint_states_in)}'
            if cfg.joint_states_in
            else ''
        )
    )


def one_line(text: str, limit: int = 400) -> str:
    """``text`` on one line (whitespace runs, line breaks too, become one space), cut to
    ``limit`` characters: a reason for a log line and a diagnostic message."""
    flat = ' '.join(text.split())
    return flat if len(flat) <= limit else flat[: limit - 3] + '...'


#: When the node looks at the graph for another node of its name (s after start-up, times)
CLASH_CHECK_S = 1.0
CLASH_CHECKS = 10


class NameClashCheck:
    """Another node of this name in this namespace mixes its answers, status and parameter
    services with ours: look at the graph once discovery has had time to see it (a few times
    during the first seconds, then never again), and log an error if it holds one."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.checks = 0
        self.timer = node.create_timer(CLASH_CHECK_S, self.check)

    def check(self) -> None:
        self.checks += 1
        me = (self.node.get_name(), self.node.get_namespace())
        count = sum(1 for n in self.node.get_node_names_and_namespaces() if n == me)
        if count > 1 or self.checks >= CLASH_CHECKS:
            self.timer.cancel()
            self.node.destroy_timer(self.timer)
        if count > 1:
            full = self.node.get_fully_qualified_name()
            self.node.get_logger().error(
                f'{count} nodes named {full} are running: their joint_states, status and '
                'parameter services mix and requests reach both; start each with its own '
                'name or namespace (--ros-args -r __node:=NAME or -r __ns:=/NS)'
            )


#: How long the spin loop may block before it looks at the stop flag (s): the latency of a
#: shutdown on SIGINT / SIGTERM, not of any message.
STOP_POLL_S = 0.1


class StopOnSignal:
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


def spin_until_stopped(executor: Executor, stop: StopOnSignal, context: Any = None) -> None:
    """Run ``executor``'s ready callbacks until a stop is asked for or rclpy shuts down: one
    Python call per STOP_POLL_S, not one per callback (a command costs one callback). Each poll
    waits on a future of its own: the executor adds a done-callback to the future it waits on
    and never removes it, so one future kept for the node's life grew by two callbacks a poll
    (about 1.7 million a day)."""
    while stop.requested is None and rclpy.ok(context=context):
        executor.spin_until_future_complete(Future(), timeout_sec=STOP_POLL_S)


def make_executor(node: Any) -> Executor:
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
