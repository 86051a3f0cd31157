"""The node's requests: each callback is message -> plain data (conversions) -> the engine ->
one answer (Outputs.answer). A bad request is answered by exactly one ERROR status and changes
nothing; no callback raises (a bug is answered as an internal error and logged)."""

from __future__ import annotations

import math
import traceback
from collections.abc import Callable

from builtin_interfaces.msg import Time
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState

from .command_cdr import NamesMemo, joint_state_names, joint_state_peek, read_joint_state
from .conversions import (
    is_zero_stamp,
    joint_state_pick,
    joint_state_rates,
    joint_state_to_command,
    point_stamped_to_xy,
    pose_to_xy_yaw,
)
from .core.errors import CommandError
from .core.model import Mechanism
from .core.solver import Result
from .engine import Engine
from .node_protocol import ServingNode
from .plan_worker import CommandClock
from .point_coordinates import pose_target
from .request_checks import name_count_error, request_rates, request_values
from .stamps import frame_error, names_frame_error, stamp_error

ZERO_CLOCK = (
    "header.stamp is 0, and so is the node clock's now: use_sim_time is true and no "
    '/clock message has arrived yet; stamp the request, or wait for /clock'
)


class Requests:
    """The request callbacks of one node (:class:`~linkage_ros.node.LinkageNode`), answering on the
    mechanism it serves (its ``engine``, ``mech`` and ``outputs``; while it waits for a robot
    description, ``waiting`` refuses every request)."""

    def __init__(self, node: ServingNode, commands: CommandClock | None = None):
        self.node = node
        #: when a request was last answered, shared with the plan worker (it paces itself
        #: while requests come: plan_worker.Pacer)
        self.commands = commands if commands is not None else CommandClock()
        #: the names of the last ~/command read (a client sends the same ones each time)
        self.command_names = NamesMemo()

    def request_stamp(self, stamp: Time) -> tuple[Time, str | None]:
        """The stamp a request's answers carry (an unset one: the node clock's now), and why
        the request is refused for it, if it is."""
        if is_zero_stamp(stamp):  # unset: the node clock's now
            stamp = self.node.get_clock().now().to_msg()
            if is_zero_stamp(stamp):  # sim time before the first /clock
                return stamp, ZERO_CLOCK
            if self.node.outputs is not None:  # (after the joint_states before it)
                stamp = self.node.outputs.after_last(stamp)
        # a stamp rclpy / rclcpp cannot turn into a time (negative, nanosec >= 1e9) would reach
        # every consumer of the answer: refuse the request instead
        return stamp, stamp_error(stamp.sec, stamp.nanosec)

    def answer(
        self, request: str, stamp, solve: Callable[[], Result], from_client: bool = True
    ) -> Result:
        """Run one request and publish its answer (Outputs.answer: on success joint_states,
        the subscribed points and an OK status; on failure only an ERROR status). Never
        raises. A request ``from_client`` (not the node's own demo sweep) stamps the command
        clock: the plan worker paces itself while those come."""
        if self.node.outputs is None:  # no robot description yet
            return self.refuse_waiting(request)
        if from_client:
            self.commands.stamp()
        try:
            stamp, bad_stamp = self.request_stamp(stamp)
            if bad_stamp:
                result = Result(False, bad_stamp)
            else:
                try:
                    result = solve()
                except CommandError as exc:
                    result = Result(False, str(exc))
            self.node.outputs.answer(result, stamp, request)
            return result
        except Exception as exc:  # a bug must not take the node down: answer and keep going
            self.node.get_logger().error(
                f'internal error on {request}: {exc!r}\n' + traceback.format_exc()
            )
            self.node.outputs.internal_error(f'internal error: {exc!r}', request)
            return Result(False, f'internal error: {exc!r}')

    def refuse_waiting(self, request: str) -> Result:
        """Answer a request that came before any robot description: an ERROR status saying
        the node waits for one. Never raises."""
        assert self.node.waiting is not None
        try:
            self.node.waiting.answer(request)
        except Exception as exc:  # noqa: BLE001 - never raise from a callback
            self.node.get_logger().error(f'internal error on {request}: {exc!r}')
        return Result(False, self.node.waiting.reason())

    def on_command(self, msg):
        """A deserialised ~/command (the path of the bytes read_joint_state leaves to rclpy)."""
        self.answer(
            'command',
            msg.header.stamp,
            lambda: self.served_engine().command(
                joint_state_to_command(msg, self.node.max_names), joint_state_rates(msg)
            ),
        )

    def on_raw_command(self, raw: bytes) -> None:
        """~/command as it arrives, serialised: its fields read off the bytes (command_cdr),
        without the Python message rclpy would build; what the reader does not take goes
        through rclpy's deserialiser to :meth:`on_command`. Answers exactly as that would."""
        peek = joint_state_peek(raw)
        if peek is not None and peek.count > self.node.max_names:  # refused on its count alone
            why = name_count_error(peek.count, self.node.max_names)
            stamp = Time(sec=peek.sec, nanosec=peek.nanosec)
            self.answer('command', stamp, lambda: Result(False, why))
            return
        fields = None if peek is None else read_joint_state(raw, peek, self.command_names)
        if fields is None:
            try:
                msg = deserialize_message(raw, JointState)
            except Exception as exc:  # noqa: BLE001 - answer, never raise
                bad = f'not a JointState: {exc}'
                self.answer('command', Time(), lambda: Result(False, bad))
                return
            self.on_command(msg)
            return

        def solve() -> Result:
            names = fields.names
            return self.served_engine().command(
                request_values(names, fields.positions, self.node.max_names),
                request_rates(names, fields.velocities),
            )

        self.answer('command', Time(sec=fields.sec, nanosec=fields.nanosec), solve)

    def served_engine(self) -> Engine:
        """The engine being served: request callbacks exist only while one is (and answer
        refuses while waiting for a robot description)."""
        assert self.node.engine is not None
        return self.node.engine

    def served_mech(self) -> Mechanism:
        assert self.node.mech is not None
        return self.node.mech

    def on_target(self, raw: bytes):
        self.on_raw_target('target', raw, False)

    def on_target_any_mode(self, raw: bytes):
        """~/target that may change the assembly mode (explicitly asked for)."""
        self.on_raw_target('target_any_mode', raw, True)

    def on_raw_target(self, request: str, raw: bytes, any_mode: bool) -> None:
        if self.node.outputs is None:  # no robot description yet
            self.refuse_waiting(request)
            return
        # the count of names first (the words of every front end), then the length
        peek = joint_state_peek(raw)
        if peek is not None and peek.count > self.node.max_names:
            why = name_count_error(peek.count, self.node.max_names)
            stamp = Time(sec=peek.sec, nanosec=peek.nanosec)
            self.answer(request, stamp, lambda: Result(False, why))
            return
        if len(raw) > self.node.max_request_bytes:  # its length says enough: refused unread
            too_big = (
                f'JointState message is {len(raw)} bytes; a request to scene '
                f'{self.served_mech().name!r} is at most {self.node.max_request_bytes} bytes '
                '(every name the scene has, with a position, velocity and effort each)'
            )
            stamp = Time() if peek is None else Time(sec=peek.sec, nanosec=peek.nanosec)
            self.answer(request, stamp, lambda: Result(False, too_big))
            return
        try:
            msg = deserialize_message(raw, JointState)
        except Exception as exc:  # noqa: BLE001 - rmw already checked it; answer, never raise
            bad = f'not a JointState: {exc}'
            self.answer(request, Time(), lambda: Result(False, bad))
            return
        # names read whole, as ~/command and linkage bag read them (rclpy ends one at a NUL)
        whole = None if peek is None else joint_state_names(raw, peek)
        if whole is not None and tuple(msg.name) != whole:
            msg.name = list(whole)

        def solve() -> Result:
            values = joint_state_to_command(msg, self.node.max_names)
            foreign = names_frame_error(
                'target', self.served_mech(), values, msg.header.frame_id, self.node.frame_id
            )
            if foreign:
                return Result(False, foreign)
            return self.served_engine().target(values, allow_mode_change=any_mode)

        self.answer(request, msg.header.stamp, solve)

    def on_target_pose(self, link: str, msg):
        def solve():
            foreign = frame_error(
                f'target pose of {link!r}', msg.header.frame_id, self.node.frame_id
            )
            if foreign:
                return Result(False, foreign)
            x, y, yaw = pose_to_xy_yaw(msg, link)
            mech = self.served_mech()
            return self.served_engine().target(pose_target(mech, link, (x, y), yaw))

        self.answer(f'target_pose/{link}', msg.header.stamp, solve)

    def on_target_point(self, point: str, msg):

        def solve():
            foreign = frame_error(
                f'target point {point!r}', msg.header.frame_id, self.node.frame_id
            )
            if foreign:
                return Result(False, foreign)
            xy = point_stamped_to_xy(msg, point, self.served_mech())
            return self.served_engine().target_point(point, xy)

        self.answer(f'target_point/{point}', msg.header.stamp, solve)

    def on_joint_states_in(self, msg: JointState) -> None:
        """State completion: the mechanism's inputs in a hardware JointState command it; the
        answer's joint_states leave them out. A message carrying none of them (the node's own
        joint_states among others) is ignored, and so is every message before a robot
        description arrives (the inputs are not known yet). Never raises."""
        if self.node.outputs is None:
            return
        try:
            values, rates = joint_state_pick(
                msg, self.node.state_inputs | self.node.state_followers
            )
        except CommandError as exc:
            bad = str(exc)
            self.answer('joint_states_in', msg.header.stamp, lambda: Result(False, bad))
            return
        except Exception as exc:  # noqa: BLE001 - a broken message must not raise here
            bad = f'not a JointState: {exc!r}'
            self.answer('joint_states_in', msg.header.stamp, lambda: Result(False, bad))
            return
        command = {n: v for n, v in values.items() if n in self.node.state_inputs}
        if not command:
            # no input: not the hardware's (the node's own joint_states carries a follower)
            return
        followers = self.node.state_followers.intersection(values)
        if followers - self.node.outputs.omit_joints and not self.node.config.publish_inputs:
            # the hardware publishes a mimic follower too
            self.node.outputs.set_omit_joints(self.node.outputs.omit_joints | followers)
        # joint_state_broadcaster fills a joint without a velocity interface with NaN: such
        # rates are no rates, positions alone command
        if rates is not None and all(math.isfinite(rates[n]) for n in command):
            command_rates: dict[str, float] | None = {n: rates[n] for n in command}
        else:
            command_rates = None
        engine = self.node.engine
        assert engine is not None
        self.answer(
            'joint_states_in', msg.header.stamp, lambda: engine.command(command, command_rates)
        )
