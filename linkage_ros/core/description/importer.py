"""A robot description -> an assembled scene (the general form, in the description's names)
and the JointMap of its joint coordinates. One pipeline for every format: read -> closures
from side files -> the chain in its plane -> assemble at the actuated values -> scene."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import SceneError
from ..model import Mechanism, Scene
from ..model.joint_map import JointMap, OutputKind
from ..model.limits import limit_violation, spans_a_turn, written_in_degrees
from .assembly import CLOSED, assemble_chain, values_text
from .calibration import calibrate_joint_map
from .chain import Chain, find_chain, rot
from .records import Description, DescriptionError, DescriptionFormat
from .scene_names import SceneNames
from .sdf_reader import read_sdf
from .side_files import apply_side_file, load_side_file, read_file
from .urdf_reader import read_urdf
from .xml_text import MAX_DESCRIPTION_BYTES, parse_xml

#: the length of each link's axis mark (its second point) as a fraction of the chain's size
AXIS_MARK = 0.25
DESCRIPTION_SUFFIXES = ('.urdf', '.sdf', '.xml', '.xacro')


@dataclass(frozen=True, eq=False)
class Imported:
    """A description read, assembled and turned into a scene."""

    description: Description
    chain: Chain
    scene: dict[str, Any]  # the general-form scene mapping (``linkage import`` writes it)
    mechanism: Mechanism
    joint_map: JointMap
    actuated: tuple[str, ...]
    values: dict[str, float]  # every chain joint's value in the assembled reference pose
    gap: float  # m: how far the loops were open at the actuated values before assembly
    notes: tuple[str, ...]  # what the node logs at start-up (superseded mimics, the gap)


def is_description(path_or_text: str) -> bool:
    """True for a description path (.urdf, .sdf, .xml) or URDF/SDF text."""
    s = path_or_text.lstrip()
    return s.startswith('<') or path_or_text.lower().endswith(DESCRIPTION_SUFFIXES)


def read_description(text: str, source: str) -> Description:
    root = parse_xml(text, source)
    if root.tag == 'robot':
        return read_urdf(root, source)
    if root.tag == 'sdf':
        return read_sdf(root, source)
    raise DescriptionError(
        f'the root element is <{root.tag}>, not <robot> (URDF) or <sdf>', file=source
    )


def import_description(
    description: str,
    closures: str | None = None,
    actuated: Sequence[str] | None = None,
    values: Mapping[str, float] | None = None,
    dimensions: Mapping[str, float] | None = None,
    text: bool = False,
) -> Imported:
    """Read ``description`` (a path, or URDF/SDF text with ``text``), add the closures of the
    side file ``closures``, and assemble at ``values`` of the actuated joints (default 0)."""
    source = '<robot_description>' if text else description
    body = (
        description if text else read_file(description, MAX_DESCRIPTION_BYTES, 'robot description')
    )
    desc = read_description(body, source)
    if closures:
        desc = apply_side_file(desc, load_side_file(closures), closures)
    seen: set[str] = set()
    for c in desc.closures:  # (a closure's pin and a joint's of one name would be one point)
        if c.name in seen:
            raise DescriptionError(
                f'two closures are named {c.name!r} (<loop>, <constraint> or closure file '
                'entries): give each a name of its own',
                file=closures or source,
                value=c.name,
            )
        seen.add(c.name)
        if desc.joint(c.name) is not None:
            raise DescriptionError(
                f'closure {c.name!r} has the name of a joint of the description: give the '
                'closure a name of its own',
                file=closures or source,
                value=c.name,
            )
    if actuated:
        for n in actuated:
            if desc.joint(n) is None:
                loop = any(c.name == n for c in desc.closures)
                raise DescriptionError(
                    'is the loop joint that closes the chain (a closure): it cannot be '
                    'actuated; actuate a joint of the tree'
                    if loop
                    else 'names no joint of the description',
                    file=source,
                    key='actuated',
                    value=n,
                )
        desc = replace(desc, actuated=tuple(actuated))
    chain = find_chain(desc)
    acts = _actuated(chain)
    q, gap, tied = assemble_chain(
        chain, acts, _assembly_values(chain, acts, desc, values, closures)
    )
    scene, names = _scene(chain, acts, q, dimensions)
    try:
        mech = Scene.from_dict(scene, source=source).mechanism
    except DescriptionError:
        raise
    except SceneError as exc:  # e.g. the assembled pose outside a <limit>: say how to move it
        raise DescriptionError(
            f'{exc}; for a robot description: assemble it elsewhere with assemble_at in its '
            'closure file, or state its limits there'
        ) from None
    jmap = calibrate_joint_map(chain, acts, q, mech, names)
    mech = replace(mech, joint_coordinates=jmap)
    notes = []
    if gap > CLOSED * chain.length_scale:
        notes.append(
            f'the description is open by {gap:.6g} m at '
            f'{values_text(acts, q)}: assembled (the loops closed)'
        )
    for pc in chain.closures:  # the plane's motion never moves a frame along its normal
        c = pc.closure
        apart = abs(chain.depth(c.a.link, c.a.pose) - chain.depth(c.b.link, c.b.pose))
        if apart > CLOSED * chain.length_scale:
            notes.append(
                f'closure {c.name!r} closes in the plane only: its two frames are {apart:.6g} m '
                "apart along the plane's normal in every configuration (a tool that reads the "
                'description in 3-D sees the loop open by that much)'
            )
    if tied:
        notes.append(
            "the description's pose is as near two assembly modes (starts a hair either side "
            'of it close the loops in each): the one taken was chosen by rounding, and a '
            'frame convention that does not change the robot may choose the other. State the '
            "mode: --branch (the node's branch parameter) with the signs linkage check "
            'prints, or assemble_at values nearer the one meant'
        )
    for j in chain.joints:
        lim = desc.limits_of(j.joint)
        if j.revolute and written_in_degrees(lim.lower, lim.upper):
            notes.append(
                f'the limits of {j.name} ({lim.lower:g} .. {lim.upper:g} rad) span a full turn '
                'or more and reach beyond two turns: read as degrees, it is not limited '
                '(limits are in radians)'
            )
    renamed = [
        f'{"link" if kind == "link" else "point of"} {raw!r}: {name}'
        for (kind, raw), name in names.renamed.items()
        if kind in ('link', 'point')
    ]
    if renamed:  # (joint values keep the description's names; links and points are the scene's)
        notes.append(
            'scene names are letters, digits and _, and these changed (name them so in '
            'targets and read them so in answers): ' + ', '.join(renamed)
        )
    mimics = [j.name for j in chain.joints if j.joint.mimic is not None and j.name not in acts]
    if mimics:
        notes.append(f'<mimic> of {", ".join(mimics)} superseded: the closures give their values')
    notes += _turning_mimics(jmap)
    return Imported(desc, chain, scene, mech, jmap, acts, q, gap, tuple(notes))


def _actuated(chain: Chain) -> tuple[str, ...]:
    desc = chain.description
    names = {j.name for j in chain.joints}
    if desc.actuated is not None:
        for n in desc.actuated:
            if n not in names:
                raise DescriptionError(
                    f'actuated joint {n!r} is not in the closed chain (it is above or beside it)',
                    file=desc.source,
                )
        acts = [j.name for j in chain.joints if j.name in desc.actuated]
    else:
        acts = [
            j.name
            for j in chain.joints
            if j.joint.independent or (j.joint.independent is None and j.joint.mimic is None)
        ]
    dof = len(chain.joints) - 2 * len(chain.closures)
    if dof != len(acts):
        raise DescriptionError(
            (
                'the closed chain is over-constrained: it has '
                if dof < 0
                else 'the closed chain has '
            )
            + f'{dof} degree(s) of freedom ({len(chain.joints)} joints, '
            f'{len(chain.closures)} closure(s)) but {len(acts)} joint(s) are actuated '
            f'({", ".join(acts) or "none"}'
            + _dof_hints(chain, acts, dof)
            + (
                (
                    '; a joint without <effort>0</effort> in its limit counts as actuated'
                    if desc.format is DescriptionFormat.SDF
                    else '; a joint without an independent mark counts as actuated'
                )
                if desc.actuated is None and dof >= 0
                else ''
            )
            + (
                '); state the actuated joints: actuated: [..] in a '
                'closure file, or --actuated / the actuated parameter '
                f'(chain joints: {", ".join(j.name for j in chain.joints)})'
                if dof >= 0
                else '); more closures than its joints can close: check the links each '
                'closure joins'
            ),
            file=desc.source,
        )
    return tuple(acts)


def _dof_hints(chain: Chain, acts: Sequence[str], dof: int) -> str:
    """What likely makes the count of actuated joints differ from the chain's freedom: a
    closure stated twice (two joining the same two links: the description's own loop and a
    closure file's), or, with too few, a loop without an actuated joint whose first joint
    (nearest the root) follows an actuated one by its <mimic> (a gripper's second knuckle:
    listed, it stays the follower)."""
    hints = []
    seen: dict[frozenset[str], str] = {}
    for c in chain.closures:
        pair = frozenset((c.closure.a.link, c.closure.b.link))
        if pair in seen:
            hints.append(
                f'closure {c.name!r} joins {c.closure.a.link} and {c.closure.b.link} as '
                f'{seen[pair]!r} does: stated twice?'
            )
        seen.setdefault(pair, c.name)
    if dof < 0:  # (a closure between links one joint already joins, or a frame end on the
        # link it was not meant for: each pin takes 2 freedoms, each joint gives 1)
        hints += [f'closure {c.name!r} joins links {c.a} and {c.b}' for c in chain.closures]
    if dof > len(acts):
        into = {j.child: j for j in chain.joints}  # (a link's joint from its parent)

        def up(link: str) -> list[str]:  # the joints from a link up to the chain's root
            out = []
            while link in into:
                out.append(into[link].joint.name)
                link = into[link].parent
            return out

        order = [j.joint.name for j in chain.joints]  # (parents before children)
        by_name = {j.joint.name: j.joint for j in chain.joints}
        for c in chain.closures:
            loop = sorted(set(up(c.closure.a.link)) ^ set(up(c.closure.b.link)), key=order.index)
            first = by_name[loop[0]] if loop else None
            if (
                first is not None
                and not set(loop) & set(acts)
                and first.mimic is not None
                and first.mimic.joint in acts
            ):
                hints.append(
                    f'loop {c.name!r} has no actuated joint, and its {first.name} follows '
                    f'{first.mimic.joint} by <mimic>: list it too (it keeps following its leader)'
                )
    return ''.join(f'; {h}' for h in hints)


def _turning_mimics(jmap: JointMap) -> list[str]:
    """A note for each published <mimic> that jumps where its leader wraps: the leader turns
    further than a full turn (continuous, or its published limits, the closure file's where it
    states them, 2 pi apart or more) and is published wrapped, and the follower is a length, or
    an angle by a multiplier that is not a whole number (a whole number of turns is no jump)."""
    leaders = {o.name: o for o in jmap.outputs}
    notes = []
    for o in jmap.outputs:
        lead = leaders.get(o.leader) if o.kind is OutputKind.MIMIC else None
        if lead is None or not lead.revolute or (o.revolute and float(o.scale).is_integer()):
            continue
        lo, hi = lead.lower, lead.upper
        if lo is None or hi is None or spans_a_turn(lo, hi):
            notes.append(
                f'<mimic> {o.name} = {o.scale:g} * {o.leader} + {o.offset:g}: {o.leader} turns '
                f'fully and is published wrapped (into (-pi, pi] or its limits), so {o.name} '
                f'follows that value and jumps where {o.leader} passes its wrap; turns are not '
                'counted'
            )
    return notes


def _assembly_values(
    chain: Chain,
    acts: Sequence[str],
    desc: Description,
    values: Mapping[str, float] | None,
    side: str | None = None,
) -> dict[str, float]:
    """The actuated joints' values to assemble at (a closure file's assemble_at, then the
    caller's; ``side``: the closure file, which a refusal of its limits names): a passive
    joint is refused (the loops place it), and a mimic follower takes its leader's value by the
    mimic (stating it otherwise is refused)."""
    given = {**desc.assemble_at, **(values or {})}
    by_name = {j.name: j for j in chain.joints}

    def leader_of(name: str) -> str | None:
        mimic = by_name[name].joint.mimic
        return mimic.joint if mimic is not None and mimic.joint in acts else None

    for name in given:
        if name not in acts:
            settable = [a for a in acts if leader_of(a) is None]
            raise DescriptionError(
                f'assemble_at: {name!r} is not an actuated joint (the closed chain places the '
                f'others); give values of {", ".join(settable)}',
                file=desc.source,
            )
    for name in acts:
        mimic = by_name[name].joint.mimic
        if mimic is None or mimic.joint not in acts:
            continue
        want = mimic.multiplier * given.get(mimic.joint, 0.0) + mimic.offset
        if name in given and abs(given[name] - want) > 1e-12 * max(1.0, abs(want)):
            raise DescriptionError(
                f'assemble_at: {name!r} follows {mimic.joint!r} by its <mimic> ({want:.9g} '
                f'there), not {given[name]:.9g}: give {mimic.joint!r} only',
                file=desc.source,
            )
        given[name] = want
    for name in acts:  # within the description's limits, by the one limit rule
        value = given.get(name, 0.0)
        lim = desc.limits_of(by_name[name].joint)
        if by_name[name].revolute and (lim.lower is None) != (lim.upper is None):
            # an angle's range is an arc: one end bounds nothing (a description's own single
            # end is read so, as its commands are); a closure file is asked for both
            if name in desc.limits:
                raise DescriptionError(
                    f'limits of the actuated joint {name}: an angle needs both lower and upper '
                    '(its range is an arc of the circle); state both',
                    file=side or desc.source,
                    key=f'limits.{name}',
                )
            continue
        revolute = by_name[name].revolute
        if revolute and written_in_degrees(lim.lower, lim.upper):
            continue  # (limits nothing: noted below)
        unit = 'rad' if revolute else 'm'
        # as a command is judged (ROBOT_DESCRIPTIONS.md): the value as given, not a turn of it
        # (assemble_at: {crank: 30} was assembled at 30 - 5 turns without a word, where
        # --set crank=30 is refused)
        why = limit_violation(name, value, lim.lower, lim.upper, unit, False)
        if why is None:
            continue
        whose = 'limits in the closure file' if name in desc.limits else '<limit>'
        lo_text = '-inf' if lim.lower is None else f'{lim.lower:g}'
        span = f'[{lo_text}, {"inf" if lim.upper is None else f"{lim.upper:g}"}]'
        stated = (
            'assemble_at'
            if name in desc.assemble_at
            else 'the value asked'
            if name in given
            else 'no assemble_at: 0'
        )
        mimic = by_name[name].joint.mimic
        if leader_of(name) is not None and mimic is not None:  # (set by its leader's value)
            stated = f'{name} = {mimic.multiplier:g} * {mimic.joint} + {mimic.offset:g}'
            remedy = f'give {mimic.joint} a value that puts {name} within them (assemble_at'
        else:
            inside = _inside(lim.lower, lim.upper)
            remedy = f'give a value within the limits (assemble_at: {{{name}: {inside:.6g}}}'
        raise DescriptionError(
            f'{why} where the description is assembled ({stated}; {whose}: {span}): '
            f'the assembled pose is the reference pose, the first state; {remedy} in a '
            'closure file), or state wider limits there',
            file=desc.source,
        )
    return given


def _inside(lower: float | None, upper: float | None) -> float:
    """A value within the limits [lower, upper] to suggest: their middle; with one limit (a
    length's), a value a little inside it."""
    if lower is not None and upper is not None:
        return 0.5 * (lower + upper)
    if lower is not None:
        return lower + 0.1 * max(1.0, abs(lower))
    assert upper is not None  # (a violation needs a limit)
    return upper - 0.1 * max(1.0, abs(upper))


def _all_finite(points: Mapping[str, list[float]], names: SceneNames, source: str) -> None:
    """Refuses a description whose assembled pins (or link axes) are beyond the float range,
    naming the joint, closure or link they come from (an <origin> of 1e300 m was refused
    naming the scene's internal point world_axis)."""
    for p, xy in points.items():
        if all(math.isfinite(v) for v in xy):
            continue
        raw = next((r for (kind, r), n in names.of.items() if n == p), p)
        what = raw.removesuffix('_axis') if p.endswith('_axis') else raw
        kind = 'link' if p.endswith('_axis') else 'joint or closure'
        raise DescriptionError(
            f'{kind} {what!r} is placed beyond the float range (at {xy}): an <origin> or a '
            'chain of them too large for a planar chain',
            file=source,
        )


def _scene(
    chain: Chain,
    acts: Sequence[str],
    q: Mapping[str, float],
    dimensions: Mapping[str, float] | None,
) -> tuple[dict[str, Any], SceneNames]:
    desc = chain.description
    poses = chain.poses(q)
    names = SceneNames(
        [*chain.bodies, *(j.name for j in chain.joints)] + [c.name for c in chain.closures]
    )
    link_name = {b: names('link', b) for b in chain.bodies}
    points: dict[str, list[float]] = {}
    members: dict[str, list[str]] = {b: [] for b in chain.bodies}
    sliders: list[dict[str, Any]] = []
    actuators: dict[str, dict[str, Any]] = {}

    def place(body: str, local: np.ndarray) -> np.ndarray:
        t, phi = poses[body]
        at: np.ndarray = t + rot(phi) @ local
        return at

    def slide(
        name: str, guide: str, slider: str, origin: np.ndarray, direction: np.ndarray
    ) -> None:
        """A scene slider: ``name``'s point of ``slider`` runs on the line through ``origin``
        (the guide's point, zero frame) along ``direction``, both in the assembled pose."""
        at = place(guide, origin)
        d = rot(poses[guide][1]) @ direction
        sliders.append(
            {
                'name': name,
                'guide': link_name[guide],
                'slider': link_name[slider],
                'point': name,
                'direction': [float(d[0]), float(d[1])],
                'origin': [float(at[0]), float(at[1])],
            }
        )

    for j in chain.joints:
        pname = names('point', j.name)
        names.depths[pname] = (
            chain.depth(j.joint.parent, j.joint.parent_to_joint)
            if j.revolute
            else chain.depth(j.joint.child, j.joint.child_to_joint)
        )
        if j.revolute:
            xy = place(j.parent, j.parent_point)
            points[pname] = [float(xy[0]), float(xy[1])]
            members[j.parent].append(pname)
            members[j.child].append(pname)
        else:
            assert j.direction is not None  # a prismatic joint
            xy = place(j.child, j.child_point)
            points[pname] = [float(xy[0]), float(xy[1])]
            members[j.child].append(pname)
            slide(pname, j.parent, j.child, j.parent_point, j.direction)
    for c in chain.closures:
        pname = names('point', c.name)
        names.depths[pname] = chain.depth(c.closure.b.link, c.closure.b.pose)
        xy = place(c.b, c.point_b)
        points[pname] = [float(xy[0]), float(xy[1])]
        members[c.b].append(pname)
        if c.direction is None:
            members[c.a].append(pname)
        else:
            slide(pname, c.a, c.b, c.point_a, c.direction)
    _merge_coincident(points, members, names, chain.length_scale, {s['point'] for s in sliders})
    for s in sliders:
        while s['point'] in names.alias:
            s['point'] = names.alias[s['point']]
    outputs = [p for p in points if sum(p in members[b] for b in chain.bodies[1:]) == 1]
    outputs = [p for p in outputs if p not in members[chain.ground]]
    # each body's axis (its first two points) along its frame's x: then a link's angle is
    # the angle its frame's x makes with e1, as tf shows the frame, and every joint and
    # actuator value is the description's own (negated where a joint turns the other way)
    scale = chain.length_scale
    for b in chain.bodies:
        first = members[b][0]
        phi = poses[b][1] + _frame_x_angle(chain, b)
        mark = names('axis', f'{b}_axis')  # (its own kind: a joint may be named b_axis)
        for length in (AXIS_MARK * scale * f for f in (1.0, 0.6, 1.7, 0.35, 2.9)):
            at = [
                points[first][0] + length * math.cos(phi),
                points[first][1] + length * math.sin(phi),
            ]
            # apart from the body's other points: two points of a link must not coincide
            if all(math.dist(at, points[p]) > 1e-3 * scale for p in members[b]):
                break
        points[mark] = at
        names.depths[mark] = names.depths.get(first, 0.0)
        members[b] = [first, mark, *members[b][1:]]
    by_name = {j.name: j for j in chain.joints}
    for a in acts:
        j = by_name[a]
        lim = desc.limits_of(j.joint)
        if j.revolute:
            pivot, toward = members[j.child][:2]  # the child's axis: its angle
            spec: dict[str, Any] = {
                'type': 'angle',
                'link': link_name[j.child],
                'pivot': pivot,
                'toward': toward,
            }
            if j.parent != chain.ground:
                spec['relative_to'] = link_name[j.parent]
            # value = sign * q + k, k read off the assembled pose (0 up to rounding)
            v_ref = _angle(points, pivot, toward) - _axis_angle(
                points, members[j.parent], j.parent == chain.ground
            )
            k = math.remainder(v_ref - j.sign * q[a], 2.0 * math.pi)
            if (
                lim.lower is not None
                and lim.upper is not None
                and not spans_a_turn(lim.lower, lim.upper)
            ):  # (one limit alone is refused: _assembly_values)
                lo, hi = sorted((j.sign * lim.lower + k, j.sign * lim.upper + k))
                spec.update(min=lo, max=hi)
        else:
            spec = {'type': 'slide', 'joint': names('point', a)}
            if lim.lower is not None:
                spec['min'] = lim.lower
            if lim.upper is not None:
                spec['max'] = lim.upper
        actuators[names('point', a)] = spec
    _all_finite(points, names, desc.source)
    scene: dict[str, Any] = {
        'name': names('scene', desc.name),
        'frame_id': chain.ground,
        'points': points,
        'ground': link_name[chain.ground],
        'links': {link_name[b]: members[b] for b in chain.bodies},
        'outputs': outputs,
    }
    if sliders:
        scene['sliders'] = sliders
    if actuators:
        scene['actuators'] = actuators
    dims = dict(desc.dimensions) | dict(dimensions or {})
    if dims:
        scene['dimensions'] = dims
    return scene, names


def _frame_x_angle(chain: Chain, body: str) -> float:
    """The angle (rad, from e1 about n) of ``body``'s frame x at all joint values zero; 0
    where that x is along n (a frame turned out of the plane: no direction in it)."""
    x = chain.project(chain.zero_poses[body][:3, 0])
    if math.hypot(float(x[0]), float(x[1])) < _OUT_OF_PLANE:
        return 0.0
    return math.atan2(float(x[1]), float(x[0]))


#: a frame x whose part in the plane is shorter than this lies along n (a unit vector)
_OUT_OF_PLANE = 1e-6


def _angle(points: Mapping[str, list[float]], a: str, b: str) -> float:
    (ax, ay), (bx, by) = points[a], points[b]
    return math.atan2(by - ay, bx - ax)


def _axis_angle(points: Mapping[str, list[float]], members: Sequence[str], ground: bool) -> float:
    """A link's reported angle in the reference pose: its first two points' direction; the
    ground's angles are measured from +x, and a one-point link's rotation starts at 0."""
    if ground or len(members) < 2:
        return 0.0
    return _angle(points, members[0], members[1])


def _merge_coincident(
    points: dict[str, list[float]],
    members: dict[str, list[str]],
    names: SceneNames,
    scale: float,
    keep: set[str],
) -> None:
    """Pins of one body at one place are one pin (three links meeting there: a compound
    hinge, which the scene makes one joint per child). A slider's point with a pin of its
    block at the same place (a slider-crank's block pinned at its slide frame) becomes that
    pin: the slider keeps its name and runs on the pin's point."""
    tol = 1e-9 * scale
    for pts in members.values():
        for i, p in enumerate(pts):
            if p in names.alias:
                continue
            for r in pts[:i]:
                r = names.alias.get(r, r)
                if r == p or {p, r} <= keep or math.dist(points[p], points[r]) > tol:
                    continue
                if r in keep:  # a slider's point is the pin's
                    names.alias[r] = p
                else:
                    names.alias[p] = r
                break
    for body, pts in members.items():
        merged: list[str] = []
        for p in pts:
            while p in names.alias:
                p = names.alias[p]
            if p not in merged:
                merged.append(p)
        members[body] = merged
    for p in names.alias:
        points.pop(p, None)


__all__ = ['Imported', 'import_description', 'is_description', 'read_description']
