"""Message <-> plain-data helpers for the linkage node.

Pure functions: no node, no clock, no maths beyond copying numbers between a core
:class:`~linkage_ros.core.solver.Result` and standard ROS 2 messages
(sensor_msgs/JointState, geometry_msgs/PointStamped, visualization_msgs/MarkerArray,
diagnostic_msgs/DiagnosticStatus). Units are REP-103: radians and metres.
"""

from __future__ import annotations

import math
from collections.abc import Container, Iterable, Mapping, Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point, PointStamped, PoseStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Header
from visualization_msgs.msg import Marker, MarkerArray

from .core.errors import CommandError
from .core.model import Mechanism, SlideActuator
from .core.solver import Result
from .request_checks import pick_refusal, request_rates, request_values, status_texts

__all__ = [
    'joint_state_to_command',
    'joint_state_pick',
    'point_stamped_to_xy',
    'is_zero_stamp',
    'result_to_joint_state',
    'result_to_points',
    'result_to_status',
    'error_status',
    'result_to_markers',
    'marker_layout',
    'format_joints',
]


# ---- inbound -----------------------------------------------------------------------------------


def joint_state_to_command(msg: JointState, max_names: int | None = None) -> dict[str, float]:
    """``{name: position}`` from a JointState command or target.

    Checks only the message's own shape: at least one name, as many positions as names, no
    empty or repeated name. Whether the names and values make sense for the mechanism (unknown
    or missing names, NaN, inf, limits, reachability) is the solver's call. ``velocity`` and
    ``effort`` are ignored here (:func:`joint_state_rates` reads velocity).
    """
    # the message's own sequences: the name count is checked before any copy or per-name work
    return request_values(msg.name, msg.position, max_names)


def joint_state_rates(msg: JointState) -> dict[str, float] | None:
    """``{name: velocity}`` of a JointState command, None if its velocity is empty."""
    return request_rates(msg.name, msg.velocity)


def joint_state_pick(
    msg: JointState, wanted: Container[str]
) -> tuple[dict[str, float], dict[str, float] | None]:
    """``({name: position}, {name: velocity} or None)`` of the names in ``wanted`` that ``msg``
    carries (state completion: the mechanism's inputs in a hardware JointState, which may carry
    any number of other joints). Velocities are read only when the message has one per name.
    A message whose positions do not line up with its names, or that repeats a wanted name, is
    refused (CommandError) if it carries a wanted name at all; ``({}, None)`` when it carries
    none."""
    names = msg.name
    picked = [(i, n) for i, n in enumerate(names) if n in wanted]
    if not picked:
        return {}, None
    why = pick_refusal(names, len(msg.position), wanted)
    if why:
        raise CommandError(why)
    values = {n: float(msg.position[i]) for i, n in picked}
    rates = (
        {n: float(msg.velocity[i]) for i, n in picked} if len(msg.velocity) == len(names) else None
    )
    return values, rates


def point_stamped_to_xy(
    msg: PointStamped, name: str = '', mech: Mechanism | None = None
) -> tuple[float, float]:
    """The planar (x, y) of a PointStamped (m). z is ignored (mechanisms live in the xy plane;
    with ``mech``, the point is projected into its plane: a robot description's chain lies in a
    plane of its ground link's 3-D frame), but like x and y it must be finite: a NaN or inf
    anywhere is a broken message, refused with a CommandError naming the coordinate (and
    ``name``, the target point, if given)."""
    p = msg.point
    x, y, z = float(p.x), float(p.y), float(p.z)
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        bad = ', '.join(
            f'point.{k} = {v}' for k, v in (('x', x), ('y', y), ('z', z)) if not math.isfinite(v)
        )
        head = f'target point {name!r}: ' if name else ''
        raise CommandError(
            f'{head}{bad} is not finite (every coordinate must be a finite '
            'number; z is ignored only when it is)'
        )
    return (x, y) if mech is None else mech.plane_xy(x, y, z)


#: how far (in quaternion components, after normalising) an orientation may tilt out of the
#: plane and still be read as a rotation about z
PLANAR_TOLERANCE = 1e-6


def pose_to_xy_yaw(msg: PoseStamped, name: str = '') -> tuple[float, float, float]:
    """The planar pose (x, y in m, yaw in rad about +z) of a PoseStamped. Every number must be
    finite, and the orientation a rotation about z (x and y of the unit quaternion within
    PLANAR_TOLERANCE of 0): anything else is refused with a CommandError naming it."""
    p, q = msg.pose.position, msg.pose.orientation
    head = f'target pose {name!r}: ' if name else ''
    values = [('position.x', p.x), ('position.y', p.y), ('position.z', p.z)]
    values += [('orientation.x', q.x), ('orientation.y', q.y)]
    values += [('orientation.z', q.z), ('orientation.w', q.w)]
    bad = [f'{k} = {v}' for k, v in values if not math.isfinite(v)]
    if bad:
        raise CommandError(f'{head}{", ".join(bad)} is not finite')
    # hypot: the squares of a quaternion scaled by 1e300 overflow (it was read as yaw 0)
    norm = math.hypot(q.x, q.y, q.z, q.w)
    if not norm > 1e-9:
        raise CommandError(f'{head}the orientation quaternion is zero (give w = 1 for yaw 0)')
    qx, qy, qz, qw = q.x / norm, q.y / norm, q.z / norm, q.w / norm
    if abs(qx) > PLANAR_TOLERANCE or abs(qy) > PLANAR_TOLERANCE:
        raise CommandError(
            f'{head}the orientation is not a rotation about z (normalised quaternion x = '
            f'{qx:.3g}, y = {qy:.3g}; a planar mechanism has only a yaw)'
        )
    return float(p.x), float(p.y), 2.0 * math.atan2(qz, qw)


def is_zero_stamp(stamp: Time) -> bool:
    """True for the unset stamp (0 s, 0 ns)."""
    return stamp.sec == 0 and stamp.nanosec == 0


# ---- outbound ----------------------------------------------------------------------------------


def result_to_joint_state(
    result: Result,
    mech: Mechanism,
    stamp: Time,
    frame_id: str,
    reuse: JointState | None = None,
    prefix: str = '',
    omit: frozenset[str] = frozenset(),
) -> JointState:
    """Every published joint of ``mech`` (mech.output_joint_names: the scene's, or a robot
    description's own names and values) with its position, less the names in ``omit`` (state
    completion: the joints the hardware publishes itself).

    Revolute: rad; prismatic: m. velocity (rad/s, m/s) for every joint when the result carries
    rates (a command that gave velocities), else empty; effort is always empty (kinematics only).
    ``reuse``: a message made by an earlier call with the same names and frame, refilled in
    place (a publisher serialises on publish, so one message can carry every answer).
    ``prefix`` is prepended to each published name (the node's ``prefix`` parameter).
    """
    names = mech.output_joint_names
    positions = [float(v) for v in mech.output_joints(result.joints, result.inputs)]
    vel = result.velocity
    rates = (
        [float(v) for v in mech.output_joint_rates(vel.joints)]
        if vel is not None and vel.success
        else []
    )
    if omit:
        keep = [i for i, n in enumerate(names) if n not in omit]
        names = [names[i] for i in keep]
        positions = [positions[i] for i in keep]
        rates = [rates[i] for i in keep] if rates else []
    if reuse is not None:
        reuse.header.stamp = stamp
        reuse.position = positions
        reuse.velocity = rates
        return reuse
    msg = JointState()
    msg.header = Header(stamp=stamp, frame_id=frame_id)
    msg.name = [prefix + j for j in names]
    msg.position = positions
    msg.velocity = rates
    return msg


def result_to_points(
    result: Result,
    names: Iterable[str],
    stamp: Time,
    frame_id: str,
    reuse: dict[str, PointStamped] | None = None,
    mech: Mechanism | None = None,
) -> dict[str, PointStamped]:
    """``{name: PointStamped}`` for each named point of a successful result (z = 0; with
    ``mech``, in its frame's 3-D coordinates: mech.point_3d).
    ``reuse``: messages of an earlier call with the same frame, refilled in place (and any
    missing one added to it): a publisher serialises on publish, so one message per point can
    carry every answer, which saves building a header and a point each time."""
    out = {}
    for name in names:
        x, y = result.points[name]
        z = 0.0
        if mech is not None and mech.joint_coordinates is not None:
            x, y, z = mech.point_3d(name, x, y)
        msg = reuse.get(name) if reuse is not None else None
        if msg is None:
            msg = PointStamped()
            msg.header = Header(stamp=stamp, frame_id=frame_id)
            msg.point = Point(x=float(x), y=float(y), z=float(z))
            if reuse is not None:
                reuse[name] = msg
        else:
            msg.header.stamp = stamp
            pt = msg.point
            pt.x, pt.y, pt.z = float(x), float(y), float(z)
        out[name] = msg
    return out


def _key_values(pairs: Mapping[str, str]) -> list[KeyValue]:
    return [KeyValue(key=k, value=v) for k, v in pairs.items()]


def result_to_status(
    result: Result, name: str, request: str = 'command', hardware_id: str = ''
) -> DiagnosticStatus:
    """One DiagnosticStatus answering one request.

    Success: level OK, message 'ok', values residual (fraction of the length scale), branch,
    branch_defined, margin, solver, iterations, cond (Newton only) and request.
    Failure: level ERROR, message = the reason, values request.
    """
    if not result.success:
        return error_status(result.reason or 'failed', name, request, hardware_id)
    return DiagnosticStatus(
        level=DiagnosticStatus.OK,
        name=name,
        message='ok',
        hardware_id=hardware_id,
        values=_key_values(status_texts(result, request)),
    )


def error_status(
    reason: str, name: str, request: str = 'command', hardware_id: str = ''
) -> DiagnosticStatus:
    """Level ERROR with ``reason`` as the message."""
    return DiagnosticStatus(
        level=DiagnosticStatus.ERROR,
        name=name,
        message=str(reason),
        hardware_id=hardware_id,
        values=_key_values(status_texts(Result(False, reason), request)),
    )


_GROUND = ColorRGBA(r=0.55, g=0.55, b=0.55, a=1.0)
_PALETTE = [
    ColorRGBA(r=r, g=g, b=b, a=1.0)
    for r, g, b in (
        (0.12, 0.47, 0.71),
        (1.0, 0.5, 0.05),
        (0.17, 0.63, 0.17),
        (0.84, 0.15, 0.16),
        (0.58, 0.4, 0.74),
        (0.55, 0.34, 0.29),
        (0.89, 0.47, 0.76),
        (0.74, 0.74, 0.13),
        (0.09, 0.75, 0.81),
    )
]
_JOINT = ColorRGBA(r=0.1, g=0.1, b=0.1, a=1.0)
_OUTPUT = ColorRGBA(r=0.0, g=0.8, b=0.2, a=1.0)


def _xyz(xyz) -> Point:
    """A scene point in its frame's 3-D coordinates (mech.point_3d) as a Point."""
    return Point(x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2]))


def result_to_markers(
    result: Result, mech: Mechanism, stamp: Time, frame_id: str, ns: str = 'linkage'
) -> MarkerArray:
    """RViz markers of a solved configuration (:func:`marker_layout`), drawn through the
    result's points."""
    out, drawn = marker_layout(mech, stamp, frame_id, ns)
    for marker, names in zip(out.markers, drawn, strict=True):
        marker.points = [_xyz(mech.point_3d(p, *result.points[p])) for p in names]
    return out


def marker_layout(
    mech: Mechanism, stamp: Time, frame_id: str, ns: str = 'linkage'
) -> tuple[MarkerArray, list[tuple[str, ...]]]:
    """RViz markers of ``mech`` without their points, and for each marker the scene points it
    is drawn through, in order (each as mech.point_3d places it). Stable ids, so each update
    replaces the last; what is drawn depends on the mechanism alone, never on a configuration:

    * one LINE_STRIP per link with two or more points (closed for plates of three or more),
      ground grey, moving links coloured; namespace ``<ns>/links``, id = the link's index;
    * one LINE_LIST per hydraulic cylinder, pin to pin, on its barrel link's id;
    * one SPHERE_LIST of every joint centre (``<ns>/joints``, id 0);
    * one SPHERE_LIST of the output points (``<ns>/outputs``, id 0), if there are any.

    Line width and sphere size follow the mechanism's length scale.
    """
    header = Header(stamp=stamp, frame_id=frame_id)
    width = 0.02 * mech.length_scale
    out = MarkerArray()
    drawn: list[tuple[str, ...]] = []
    cylinders = {
        pj.guide: pj
        for name, pj in mech.prismatics.items()
        if isinstance(act := mech.actuators.get(name), SlideActuator) and act.cylinder
    }
    colour = 0
    for idx, (lname, link) in enumerate(mech.links.items()):
        m = Marker(header=header, ns=f'{ns}/links', id=idx, action=Marker.ADD)
        m.pose.orientation.w = 1.0
        m.scale.x = width
        if lname == mech.ground:
            m.color = _GROUND
        else:
            m.color = _PALETTE[colour % len(_PALETTE)]
            colour += 1
        if len(link.points) >= 2:
            m.type = Marker.LINE_STRIP
            names = tuple(link.points)
            drawn.append(names + names[:1] if len(names) >= 3 else names)
        elif lname in cylinders:
            m.type = Marker.LINE_LIST
            m.scale.x = 1.5 * width
            drawn.append((link.points[0], cylinders[lname].point))
        else:
            continue  # a slider block or cylinder rod: shown by its joint sphere
        out.markers.append(m)
    joints = Marker(
        header=header,
        ns=f'{ns}/joints',
        id=0,
        type=Marker.SPHERE_LIST,
        action=Marker.ADD,
        color=_JOINT,
    )
    joints.pose.orientation.w = 1.0
    joints.scale.x = joints.scale.y = joints.scale.z = 2.5 * width
    seen: list[str] = []
    for rj in mech.revolutes:
        if rj.point not in seen:
            seen.append(rj.point)
    out.markers.append(joints)
    drawn.append(tuple(seen))
    if mech.outputs:
        outs = Marker(
            header=header,
            ns=f'{ns}/outputs',
            id=0,
            type=Marker.SPHERE_LIST,
            action=Marker.ADD,
            color=_OUTPUT,
        )
        outs.pose.orientation.w = 1.0
        outs.scale.x = outs.scale.y = outs.scale.z = 3.0 * width
        out.markers.append(outs)
        drawn.append(tuple(mech.outputs))
    return out, drawn


def format_joints(result: Result, joint_names: Sequence[str], inputs: Sequence[str] = ()) -> str:
    """A compact one-line summary, e.g. ``crank=+1.047 | O2=+1.047 A=-0.647 B=+0.866 O4=+1.219``."""
    head = ' '.join(f'{a}={result.inputs[a]:+.3f}' for a in inputs if a in result.inputs)
    body = ' '.join(f'{j}={result.joints[j]:+.3f}' for j in joint_names if j in result.joints)
    return f'{head} | {body}' if head else body
