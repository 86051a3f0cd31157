"""Trajectories and paths: many requests answered as one (ROS-free; the node and the bag use it).

A trajectory is a sequence of requests with the same names, one per point: actuator values
(forward kinematics; a partial set holds the others as a command does) or target values (inverse
kinematics: joints, links, actuators and points as ``<point>.x``, ``<point>.y``). It is solved
point by point from the engine's last good state, the assembly mode followed continuously: a
step that changes mode (a branch jump, a toggle crossed into another circuit; a toggle the
circuit itself passes, as a non-Grashof four-bar's, is motion) is refused, as is any point that is
unreachable, and then the whole trajectory is refused with the first failing index and why (a
robot must never execute half of a trajectory). A trajectory is a plan, not a motion: the
engine's state is the same after it as before.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from .core.errors import CommandError, echo
from .core.model import Mechanism
from .core.solver import Result
from .core.solver.result import branch_text
from .core.velocity import velocities
from .engine import Engine
from .point_coordinates import group_point_coordinates
from .request_checks import joint_names_error, max_request_names, rates_error
from .stamps import frame_error, names_frame_error, stamp_ns

#: the most points one trajectory may have (a 10 s trajectory at 1 kHz)
MAX_TRAJECTORY_POINTS = 10_000
#: the times a builtin_interfaces/Duration can carry (ns): int32 seconds, nanoseconds below 1e9
#: (a solved trajectory's time_from_start)
DURATION_MIN_NS = -(2**31) * 1_000_000_000
DURATION_MAX_NS = (2**31 - 1) * 1_000_000_000 + 999_999_999


@dataclass
class TrajectoryAnswer:
    """Every point's Result when ``success``; else the reason, naming the first failing point
    (``failed_index``, None when the request as a whole is malformed)."""

    success: bool
    reason: str = ''
    results: list[Result] = field(default_factory=list)
    failed_index: int | None = None
    inverse: bool = False

    @property
    def has_velocities(self) -> bool:
        """Every point has its joints' velocities (the request gave them, all solved)."""
        return all(r.velocity is not None and r.velocity.success for r in self.results)

    def rows(
        self, mech: Mechanism, times_ns: Sequence[int], pace: Callable[[], None] | None = None
    ) -> list[tuple[list[float], list[float], int, int]]:
        """Per point: every published joint's position (mech.output_joint_names), their
        velocities (empty unless :attr:`has_velocities`) and time_from_start as (sec,
        nanosec): what ~/solved_trajectory carries, for the node's message and the bag's alike.
        ``pace`` is called after every point (the plan worker's Pacer)."""
        rates = self.has_velocities
        out = []
        for r, t in zip(self.results, times_ns):
            sec, nanosec = divmod(int(t), 1_000_000_000)
            positions = [float(v) for v in mech.output_joints(r.joints, r.inputs)]
            vel = r.velocity
            velocities = (
                [float(v) for v in mech.output_joint_rates(vel.joints)]
                if rates and vel is not None
                else []
            )
            out.append((positions, velocities, sec, nanosec))
            if pace is not None:
                pace()
        return out

    def residual_and_margin(
        self, pace: Callable[[], None] | None = None
    ) -> tuple[float | None, float | None]:
        """The points' largest residual and smallest margin (None where no point has one).
        ``pace`` is called after every point: a closed-form Result works out its residual when
        it is first read (core.solver.closure_bound), about 12 us a four-bar point, so this was
        the plan worker's longest unpaced step (36 ms for 3000 points)."""
        largest: float | None = None
        smallest: float | None = None
        for r in self.results:
            res, m = r.residual, r.margin
            if res is not None and (largest is None or res > largest):
                largest = res
            if m is not None and (smallest is None or m < smallest):
                smallest = m
            if pace is not None:
                pace()
        return largest, smallest


# ---- reading requests (trajectory_msgs/JointTrajectory, nav_msgs/Path: rclpy's messages in the
# node, rosbags' in the bag tool; only their fields are read) -----------------------------------


class PlanPointError(CommandError):
    """A request's point (or pose) ``index`` is malformed: the status names it (failed_index),
    as a point that does not solve is named."""

    def __init__(self, index: int, reason: str):
        super().__init__(reason)
        self.index = index


def too_many_points(what: str, n: int, items: str) -> str:
    """Why a plan of ``n`` points (``items``: points, poses) is refused."""
    return (
        f'{what} has {n} {items}; at most {MAX_TRAJECTORY_POINTS} are solved in one request '
        '(send it in parts)'
    )


def duration_ns(d: Any) -> int:
    """A builtin_interfaces/Duration (or Time) in ns."""
    return stamp_ns(int(d.sec), int(d.nanosec))


def joint_trajectory_request(
    msg: Any, pace: Callable[[], None] | None = None
) -> tuple[
    list[str], list[Sequence[float]], list[Sequence[float]], list[int], PlanPointError | None
]:
    """(joint_names, positions per point, velocities per point, time_from_start ns per point,
    the first point's malformed accelerations or effort: a PlanPointError, or None);
    CommandError for more points than one request may have (checked before any copy).
    ``pace`` is called after every point (the plan worker's Pacer)."""
    if len(msg.points) > MAX_TRAJECTORY_POINTS:
        raise CommandError(too_many_points('trajectory', len(msg.points), 'points'))
    names = list(msg.joint_names)
    positions, velocities, times = [], [], []
    extra: PlanPointError | None = None
    for i, p in enumerate(msg.points):
        if extra is None:
            extra = _unused_fields_error(p, i, len(names))
        positions.append(p.positions)
        velocities.append(p.velocities)
        times.append(duration_ns(p.time_from_start))
        if pace is not None:
            pace()
    return names, positions, velocities, times, extra


def _unused_fields_error(point: Any, i: int, n_names: int) -> PlanPointError | None:
    """Point ``i``'s malformed accelerations or effort, or None: they are not used
    (kinematics only), but a malformed one is a broken request, refused as a malformed
    velocity is rather than ignored without a word."""
    for what in ('accelerations', 'effort'):
        got = getattr(point, what, ())
        if len(got) and len(got) != n_names:
            return PlanPointError(
                i,
                f'point {i} has {len(got)} {what} for {n_names} joint_names: give one '
                f'per name or none ({what} are not used: kinematics only)',
            )
        if len(got) and not all(math.isfinite(float(v)) for v in got):
            return PlanPointError(i, f'point {i}: {what} are not all finite')
    return None


def path_request(
    msg: Any,
    point: str,
    frame_id: str,
    mech: Mechanism | None = None,
    pace: Callable[[], None] | None = None,
) -> tuple[list[tuple[float, float]], list[int]]:
    """The (x, y) of every pose (m; with ``mech``, its position projected into the
    mechanism's plane: a robot description's chain lies in a plane of its 3-D frame) and each
    pose's time from the first (ns: its stamp less the first's when the stamps increase
    strictly, else 0: a path has no timing); CommandError for a frame other than the node's or
    a non-finite coordinate. ``pace`` is called after every pose (the plan worker's Pacer)."""
    if len(msg.poses) > MAX_TRAJECTORY_POINTS:
        raise CommandError(too_many_points('path', len(msg.poses), 'poses'))
    header = msg.header.frame_id
    if header and header != frame_id:
        raise CommandError(
            str(frame_error(f'path of {point!r}', header, frame_id, field='frame_id'))
        )
    xy = []
    for i, pose in enumerate(msg.poses):  # (the first failing pose named: failed_index)
        f = pose.header.frame_id
        if f and f != frame_id:  # (a pose stamped in a frame of its own)
            why = frame_error(f'path of {point!r}', f, frame_id, field='frame_id')
            raise PlanPointError(i, f'pose {i}: {why}')
        p = pose.pose.position
        for axis, v in (('x', p.x), ('y', p.y), ('z', p.z)):
            if not math.isfinite(v):
                raise PlanPointError(i, f'pose {i}: position.{axis} = {v} is not finite')
        if mech is None:
            xy.append((float(p.x), float(p.y)))
        else:
            xy.append(mech.plane_xy(float(p.x), float(p.y), float(p.z)))
        if pace is not None:
            pace()
    stamps = [duration_ns(p.header.stamp) for p in msg.poses]
    timed = all(b > a for a, b in zip(stamps, stamps[1:]))
    times = [s - stamps[0] for s in stamps] if stamps and timed else [0] * len(stamps)
    if times and times[-1] > DURATION_MAX_NS:  # (they increase: the first beyond is named)
        i = next(k for k, t in enumerate(times) if t > DURATION_MAX_NS)
        raise PlanPointError(
            i,
            f"pose {i}: its stamp is {times[i] * 1e-9:.9g} s after pose 0's, "
            f'beyond what a time_from_start can hold ({_duration_range()})',
        )
    return xy, times


def _duration_range() -> str:
    return f'{DURATION_MIN_NS // 10**9} s to {DURATION_MAX_NS // 10**9}.999999999 s'


def trajectory_status_values(
    answer: TrajectoryAnswer, request: str, pace: Callable[[], None] | None = None
) -> tuple[bool, str, dict[str, str]]:
    """(ok, message, key-values) of the one status answering a trajectory or path: OK with
    points, largest residual, smallest margin, solver and velocity (ok / none); or ERROR with
    the reason (naming the first failing point) and failed_index when there is one. ``pace``
    is called after every point read (the plan worker's Pacer)."""
    if not answer.success:
        values: dict[str, Any] = {'request': request}
        if answer.failed_index is not None:
            values = {'failed_index': answer.failed_index, **values}
        return False, answer.reason, {k: str(v) for k, v in values.items()}
    residual, margin = answer.residual_and_margin(pace)
    values = {
        'points': len(answer.results),
        'residual': residual,
        'margin': margin,
        'solver': answer.results[-1].solver,
        'velocity': 'ok' if answer.has_velocities else 'none',
        'request': request,
    }
    return True, 'ok', {k: '' if v is None else str(v) for k, v in values.items()}


def _refused(reason: str, index: int | None = None) -> TrajectoryAnswer:
    return TrajectoryAnswer(False, reason, failed_index=index)


def check_shape(
    engine: Engine,
    names: Sequence[str],
    positions: Sequence[Sequence[float]],
    velocities: Sequence[Sequence[float]],
    times_ns: Sequence[int],
) -> TrajectoryAnswer | None:
    """Why a trajectory is malformed as a message (before any solve), or None."""
    n = len(positions)
    if n == 0:
        return _refused('empty trajectory: no points')
    if n > MAX_TRAJECTORY_POINTS:
        return _refused(too_many_points('trajectory', n, 'points'))
    why = joint_names_error(names, max_request_names(engine.mech))
    if why:
        return _refused(why)
    for i, row in enumerate(positions):
        if len(row) != len(names):
            return _refused(f'point {i} has {len(row)} position(s) for {len(names)} joint_names', i)
        vel = velocities[i] if i < len(velocities) else ()
        if len(vel) not in (0, len(names)):
            return _refused(
                f'point {i} has {len(vel)} velocities for {len(names)} joint_names: give one '
                'per name or none',
                i,
            )
        if not DURATION_MIN_NS <= times_ns[i] <= DURATION_MAX_NS:
            return _refused(
                f'point {i}: time_from_start {times_ns[i] * 1e-9:.10g} s is outside what a '
                f'Duration can hold ({_duration_range()})',
                i,
            )
        if i and times_ns[i] <= times_ns[i - 1]:
            return _refused(
                f'point {i}: time_from_start {times_ns[i] * 1e-9:.9g} s is not after point '
                f"{i - 1}'s {times_ns[i - 1] * 1e-9:.9g} s (it must increase strictly)",
                i,
            )
    return None


def is_forward(engine: Engine, names: Sequence[str]) -> bool:
    """Actuator names only: forward kinematics (a partial set holds the others)."""
    return all(n in engine.forward.knowns for n in names)


def solve_trajectory(
    engine: Engine,
    names: Sequence[str],
    positions: Sequence[Sequence[float]],
    velocities: Sequence[Sequence[float]] = (),
    times_ns: Sequence[int] | None = None,
    pace: Callable[[], None] | None = None,
) -> TrajectoryAnswer:
    """Solve every point (see the module docstring); the engine's state is unchanged after.
    ``pace`` is called after every point (the plan worker's Pacer)."""
    times = list(times_ns) if times_ns is not None else list(range(len(positions)))
    bad = check_shape(engine, names, positions, velocities, times)
    if bad is not None:
        return bad
    forward = is_forward(engine, names)
    token = engine.checkpoint()
    results: list[Result] = []
    try:
        before = engine.mode(engine.last)
        for i, row in enumerate(positions):
            values: dict[str, Any] = dict(zip(names, (float(v) for v in row)))
            vel = velocities[i] if i < len(velocities) else ()
            rates = dict(zip(names, (float(v) for v in vel))) if len(vel) else None
            bad_rates = rates_error(rates)
            if bad_rates:  # as a command refuses them: forward and inverse alike
                return _refused(f'point {i}: {bad_rates}', i)
            if forward:
                r = engine.command(values, rates)
            else:  # after the first point, the continuous answer only (no jump in mode)
                r = engine.target(values, replace=not results)
                if r.success and rates is not None:
                    r.velocity = _target_rates(engine, values, rates, r)
            if not r.success:
                return _refused(f'point {i}: {r.reason}', i)
            after = engine.mode(r)
            here = results[-1] if results else engine.last
            if before is not None and engine.mode_changes(before, here, r):
                assert after is not None
                signs, signs_after = branch_text(before[0]), branch_text(after[0])
                on = (
                    (engine.circuit.holds(here), engine.circuit.holds(r))
                    if here is not None
                    else ()
                )
                change = (
                    f'the mechanism changes circuit (signs {signs} -> {signs_after}, onto a loop '
                    'its actuator does not reach from the other)'
                    if len(on) == 2 and None not in on and on[0] != on[1]
                    else f'the assembly mode changes from {signs} to {signs_after}'
                )
                return _refused(
                    f'point {i}: {change} between points {i - 1} and {i} (a branch jump or a '
                    'toggle crossed); a mechanism cannot follow that',
                    i,
                )
            before = after if after is not None else before
            results.append(r)
            if pace is not None:
                pace()
    finally:
        engine.rollback(token)
    return TrajectoryAnswer(True, results=results, inverse=not forward)


def _target_rates(
    engine: Engine, values: Mapping[str, Any], rates: Mapping[str, float], result: Result
) -> Any:
    """Every joint's rate for the rates of a target's names (the same Jacobian as a command's):
    a point's two coordinates' rates are its velocity (vx, vy), one coordinate's a rate of its
    own (m/s). None where the solver's knowns are not the names' (two points of one link: the
    plan solves the first point and the link's angle)."""
    mech = engine.mech
    knowns = group_point_coordinates(mech, values)
    solver = engine.solver_for(list(knowns))
    if isinstance(solver, str):
        return None
    bad = [n for n, v in rates.items() if not math.isfinite(v)]
    if bad:
        return None
    known_rates = group_point_coordinates(mech, rates)
    if {s.name for s in solver.specs} != set(known_rates):
        return None
    return velocities(solver, result, knowns, known_rates)


def path_targets(
    engine: Engine,
    point: str,
    xy: Sequence[tuple[float, float]],
    pace: Callable[[], None] | None = None,
) -> tuple[list[str], list[list[float]]] | str:
    """A point's successive positions -> the target names (``<point>.x``, ``<point>.y`` and,
    with more than 2 degrees of freedom, the ``target_point_hold`` names) and one row of
    values per position (the held names at their values in the last good state, as
    ``~/target_point/<point>`` holds them); or why not. ``pace`` is called after every row."""
    mech = engine.mech
    if point not in mech.points:
        return f'unknown point {echo(point)} of {mech.name!r}'
    hold = engine.point_hold(point)
    held: dict[str, Any] = {}
    if hold:
        now = engine.held_now(hold)
        if isinstance(now, str):
            return now
        held = now
        if any(isinstance(v, tuple) for v in held.values()):
            return 'a held point cannot be part of a path target; hold joints, links or actuators'
    elif mech.dof > 2:
        return (
            f'a path of {point!r} fixes 2 of the {mech.dof} degrees of freedom: set the '
            'parameter target_point_hold'
        )
    rows = []
    for x, y in xy:
        rows.append([x, y, *held.values()])
        if pace is not None:
            pace()
    return [f'{point}.x', f'{point}.y', *held], rows


def answer_trajectory_msg(
    engine: Engine,
    msg: Any,
    frame_id: str | None = None,
    pace: Callable[[], None] | None = None,
) -> tuple[TrajectoryAnswer, list[int]]:
    """A trajectory_msgs/JointTrajectory (any message with its fields) solved: the answer and
    each point's time_from_start (ns). With ``frame_id`` (the node's), a trajectory of point
    coordinates (``<point>.x``) or link angles (absolute: from the frame's +x) stamped in
    another frame is refused, as a path is. ``pace``:
    as for :func:`solve_trajectory`."""
    try:
        names, positions, velocities, times, extra = joint_trajectory_request(msg, pace)
    except CommandError as exc:
        return _refused(str(exc), getattr(exc, 'index', None)), []
    if extra is not None:
        # the first failing point: a point before it (or the whole request) may fail its shape
        before = check_shape(engine, names, positions[: extra.index + 1], velocities, times)
        if before is not None:
            return before, times
        return _refused(str(extra), extra.index), times
    if frame_id is not None:
        foreign = names_frame_error('trajectory', engine.mech, names, msg.header.frame_id, frame_id)
        if foreign:
            return TrajectoryAnswer(False, foreign), times
    return solve_trajectory(engine, names, positions, velocities, times, pace), times


def answer_path_msg(
    engine: Engine,
    point: str,
    msg: Any,
    frame_id: str,
    pace: Callable[[], None] | None = None,
) -> tuple[TrajectoryAnswer, list[int]]:
    """A nav_msgs/Path of ``point`` (any message with its fields) solved as a trajectory of
    point targets: the answer and each pose's time from the first (ns). ``pace``: as for
    :func:`solve_trajectory`."""
    try:
        xy, times = path_request(msg, point, frame_id, engine.mech, pace)
    except CommandError as exc:
        return _refused(str(exc), getattr(exc, 'index', None)), []
    targets = path_targets(engine, point, xy, pace)
    if isinstance(targets, str):
        return TrajectoryAnswer(False, targets), times
    names, rows = targets
    if not rows:
        return TrajectoryAnswer(False, 'empty path: no poses'), times
    return solve_trajectory(engine, names, rows, pace=pace), times
