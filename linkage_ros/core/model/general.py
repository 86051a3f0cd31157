"""The general form: points, links, sliders, cylinders and actuators into a Mechanism."""

from __future__ import annotations

import math
import re
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import SceneError, echo
from ..mechanism import (
    METHODS,
    NAME_RE,
    Actuator,
    Link,
    Mechanism,
    PrismaticJoint,
    RevoluteJoint,
    SceneForm,
    reference_value,
)
from .actuators import read_actuators
from .checks import TOP_KEYS, SceneContext
from .constraints import expand_constraints
from .dimensions import (
    LinkDistance,
    apply_to_shortcut,
    merge,
    parse_name,
    unit_slips,
)
from .limits import limit_violation
from .points import read_points
from .prismatics import read_cylinders, read_sliders
from .redraw import RedrawRefused, redraw
from .shortcuts import four_bar_to_general, slider_crank_to_general


def build_mechanism(
    data: Any,
    source: str = '<scene>',
    dimensions: Mapping[str, float] | None = None,
    warnings: list[str] | None = None,
) -> Mechanism:
    """Validate a scene mapping (general or shortcut form) and build the Mechanism.

    ``dimensions`` (name -> m, see :mod:`.dimensions`) override the scene's ``dimensions`` key
    of the same name; stated dimensions are used exactly and the drawing is redrawn to them.
    ``warnings`` (if given) collects what loads but is likely wrong (a bare angle beyond a
    full turn: degrees read as radians)."""
    ctx = SceneContext(source, warnings)
    if isinstance(data, Mapping) and 'points' in data and ('slots' in data or 'distances' in data):
        expanded, stated, rollers = expand_constraints(ctx, data, read_points(ctx, data))
        own = data.get('dimensions')
        if stated:  # the scene's own dimensions of the same name win
            expanded['dimensions'] = (
                {**stated, **own} if isinstance(own, Mapping) else stated if own is None else own
            )
        try:
            mech = build_mechanism(expanded, source, dimensions, ctx.warnings)
        except SceneError as exc:
            slot_error = _as_slot_error(exc, data)
            if slot_error is exc:
                raise
            raise slot_error from None
        mech.rollers = rollers
        return mech
    if isinstance(data, Mapping) and ('dimensions' in data or dimensions):
        return _with_dimensions(ctx, data, dimensions)
    if data is None:
        ctx.fail(
            '',
            'the scene is empty: it must be a YAML mapping (see docs/SCENES.md)',
            has_value=False,
        )
    if not isinstance(data, Mapping):
        ctx.fail('', 'a scene must be a YAML mapping', type(data).__name__)
    ctx.only('', data, TOP_KEYS)
    forms = [k for k in ('four_bar', 'slider_crank', 'points') if k in data]
    if len(forms) != 1:
        ctx.fail(
            '',
            'a scene needs exactly one of four_bar, slider_crank or points (general form)',
            forms,
        )
    frame_id = data.get('frame_id', 'world')
    if (
        not isinstance(frame_id, str)
        or not frame_id
        or frame_id.startswith('/')
        or any(c.isspace() for c in frame_id)
    ):
        ctx.fail(
            'frame_id',
            "must be a tf2 frame name: a non-empty string without whitespace or a leading '/'",
            frame_id,
        )
    solver = data.get('solver', 'auto')
    if solver not in METHODS:
        ctx.fail('solver', f'must be one of {list(METHODS)}', solver)
    form = SceneForm.GENERAL if forms[0] == 'points' else SceneForm(forms[0])
    if form is not SceneForm.GENERAL:
        general_keys = (
            'links',
            'ground',
            'sliders',
            'cylinders',
            'actuators',
            'slots',
            'distances',
        )
        clash = [k for k in general_keys if k in data]
        if clash:
            ctx.fail(
                clash[0],
                f'is a general-form key; it cannot be combined with the {form} '
                'shortcut (use the general form instead)',
                has_value=False,
            )
    shortcut: dict[str, Any] = {}
    if form is SceneForm.FOUR_BAR:
        general, shortcut = four_bar_to_general(ctx, data)
    elif form is SceneForm.SLIDER_CRANK:
        general, shortcut = slider_crank_to_general(ctx, data)
    else:
        general = dict(data)
    if form is not SceneForm.GENERAL and 'outputs' in data:
        general['outputs'] = data['outputs']  # a shortcut may name its published points
    default_name = (
        _stem_name(Path(source).stem)
        if source != '<scene>'
        else ('mechanism' if form is SceneForm.GENERAL else form.value)
    )
    name = ctx.name('name', data.get('name', default_name))
    # a shortcut's values were read (and warned about) above: its general form is not again
    built = ctx if form is SceneForm.GENERAL else SceneContext(source)
    mech = _build_general(built, general, name=name, frame_id=frame_id, solver=solver)
    mech.form = form
    mech.shortcut = shortcut
    _check_reference_limits(ctx, mech, form, data)
    if form is SceneForm.FOUR_BAR:
        mech.dimensions = {
            ('crank', 'O2', 'A'): shortcut['crank'],
            ('coupler', 'A', 'B'): shortcut['coupler'],
            ('rocker', 'O4', 'B'): shortcut['rocker'],
        }
    elif form is SceneForm.SLIDER_CRANK:
        mech.dimensions = {
            ('crank', 'O2', 'A'): shortcut['crank'],
            ('rod', 'A', 'B'): shortcut['rod'],
        }
    return mech


def _as_slot_error(exc: SceneError, data: Mapping[str, Any]) -> SceneError:
    """An error keyed ``sliders.NAME`` where NAME is a slot (compiled into that slider) keyed
    as the file has it, ``slots.NAME``; any other error as it is."""
    slot_names = {spec.get('name') for spec in data.get('slots') or [] if isinstance(spec, Mapping)}
    if exc.key is None or not exc.key.startswith('sliders.'):
        return exc
    name = exc.key.removeprefix('sliders.')
    if name not in slot_names:
        return exc
    return SceneError(
        exc.message, file=exc.file, key=f'slots.{name}', value=exc.value, has_value=exc.has_value
    )


def _with_dimensions(
    ctx: SceneContext, data: Mapping[str, Any], overrides: Mapping[str, float] | None
) -> Mechanism:
    """The scene with its stated dimensions: a shortcut takes them as its own parameters; a
    general-form scene is built as drawn, redrawn to them (same assembly mode, actuators at
    their drawn values) and built again from the new drawing, its solver reading the stated
    lengths exactly."""
    dims = merge(ctx.source, data.get('dimensions'), overrides)
    plain = {k: v for k, v in data.items() if k != 'dimensions'}
    drawn = build_mechanism(plain, ctx.source, warnings=ctx.warnings)  # every other key first
    if not dims:
        return drawn
    if drawn.form is not SceneForm.GENERAL:
        try:
            mech = build_mechanism(
                apply_to_shortcut(ctx.source, drawn.form, plain, dims), ctx.source
            )
        except SceneError as exc:  # the drawn scene loads: the stated dimensions are why
            stated = ', '.join(f'{k}={v:.12g}' for k, v in dims.items())
            hints = ''.join(f'; {h}' for h in unit_slips(drawn.points, dims))
            raise SceneError(f'{exc} (with the dimensions {stated}{hints})') from None
        mech.stated = dict(dims)
        return mech
    try:
        new = redraw(drawn, dims)
    except RedrawRefused as exc:
        if drawn.actuators or drawn.dof != 0:
            slips = unit_slips(drawn.points, dims)
            if slips:
                raise RedrawRefused(f'{exc} ({"; ".join(slips)})') from None
            raise
        # a structure has no input to hold: whether it assembles with the stated lengths is
        # its solve's question (refused there with the miss), not a scene error
        drawn.dimensions.update(_stated_lengths(dims))
        drawn.stated = dict(dims)
        return drawn
    plain['points'] = {p: [x, y] for p, (x, y) in new.points.items()}
    sliders = []
    for spec in plain.get('sliders') or []:
        spec = dict(spec)
        j = spec['name']
        spec['direction'] = list(new.slider_directions[j])
        if not isinstance(spec.get('origin', spec['point']), str):
            spec['origin'] = list(new.slider_origins[j])
        sliders.append(spec)
    if sliders:
        plain['sliders'] = sliders
    mech = build_mechanism(plain, ctx.source)
    mech.dimensions.update(_stated_lengths(dims))
    mech.stated = dict(dims)
    return mech


def _stated_lengths(dims: Mapping[str, float]) -> dict[tuple[str, str, str], float]:
    """The stated link lengths by (link, point, point), m (what the solvers read exactly)."""
    out = {}
    for name, value in dims.items():
        dim = parse_name(name)
        if isinstance(dim, LinkDistance):
            out[(dim.link, dim.p, dim.q)] = value
    return out


def _build_general(
    ctx: SceneContext, data: Mapping[str, Any], *, name: str, frame_id: str, solver: str
) -> Mechanism:
    """The general form, in passes: each reads one key of the scene (checking it against what
    the earlier passes built) and names the key of anything wrong."""
    points = read_points(ctx, data)
    ground, links = _read_links(ctx, data, points)
    prismatics: dict[str, PrismaticJoint] = {}
    actuators: dict[str, Actuator] = {}
    read_cylinders(ctx, data, points, links, prismatics, actuators)
    read_sliders(ctx, data, points, links, prismatics)
    cylinders = data.get('cylinders') or {}
    prismatic_keys = {
        name: f'cylinders.{name}' if name in cylinders else f'sliders.{name}' for name in prismatics
    }
    revolutes = _revolute_joints(ctx, points, links, prismatic_keys)
    read_actuators(ctx, data, ground, links, prismatics, actuators)
    outputs = _read_outputs(ctx, data, points, ground, links)
    _check_one_point_links(ctx, ground, links, prismatics)
    scale = _length_scale(points, links, prismatics)
    if scale < sys.float_info.min:
        # the solvers work in units of the scale: 1 / scale would overflow
        ctx.fail(
            'points',
            f'the mechanism is {scale:.3g} m across, below the smallest normal float '
            f'({sys.float_info.min:.3g}); draw it in larger units',
            has_value=False,
        )
    mech = Mechanism(
        name=name,
        points=points,
        links=links,
        ground=ground,
        revolutes=revolutes,
        prismatics=prismatics,
        actuators=actuators,
        outputs=outputs,
        frame_id=frame_id,
        solver=solver,
        source=ctx.source,
        length_scale=scale,
    )
    # a structure (0 DOF, no actuator) is an assembly question: where its points go, in each
    # assembly mode; it needs no input
    if mech.dof != len(actuators):
        ctx.fail(
            'actuators',
            f'the mechanism has {mech.dof} degree(s) of freedom (Kutzbach '
            f'3(n-1)-2j with n={len(links)} links, j={len(revolutes) + len(prismatics)} '
            f'joints) but {len(actuators)} actuator(s){_unjoined(mech)}',
            sorted(actuators),
        )
    return mech


#: How many links or point pairs a hint of the DOF refusal names (a message stays one line).
_HINT_NAMES = 5


def _listed(items: Sequence[str]) -> str:
    shown = ', '.join(items[:_HINT_NAMES])
    return shown + (f' and {len(items) - _HINT_NAMES} more' if len(items) > _HINT_NAMES else '')


def _unjoined(mech: Mechanism) -> str:
    """What likely makes a mechanism's DOF count wrong, for its refusal: links no chain of
    joints reaches from the ground (each floats with 3 DOF of its own), and points of different
    links drawn on one spot under two names (two points, so no joint: a pin given twice)."""
    neighbours: dict[str, set[str]] = {name: set() for name in mech.links}
    for a, b in [(j.parent, j.child) for j in mech.revolutes] + [
        (pj.guide, pj.slider) for pj in mech.prismatics.values()
    ]:
        neighbours[a].add(b)
        neighbours[b].add(a)
    reached, todo = {mech.ground}, [mech.ground]
    while todo:
        for other in neighbours[todo.pop()] - reached:
            reached.add(other)
            todo.append(other)
    hints = []
    floating = [repr(name) for name in mech.links if name not in reached]
    if floating:
        which = 'link' if len(floating) == 1 else 'links'
        hints.append(
            f'no chain of joints joins {which} {_listed(floating)} to the ground link '
            f'{mech.ground!r}'
        )
    first_at: dict[tuple[float, ...], str] = {}
    twice = []
    for p, xy in mech.points.items():
        q = first_at.setdefault(tuple(float(v) for v in xy), p)
        if q != p:
            twice.append(f'{q} and {p}')
    if twice:
        hints.append(
            f'points {_listed(twice)} are drawn on one spot but are two points, so no joint '
            'joins them: if they are one pin, give it one name'
        )
    return ''.join(f'; {h}' for h in hints)


def _coinciding(members: Sequence[str], points: Mapping[str, np.ndarray]) -> list[tuple[str, str]]:
    """Pairs of a link's points on one spot (other than its axis pair, refused on its own),
    found by their coordinates in one pass (a ground of 600 pivots: 180 000 pairs otherwise)."""
    first: dict[tuple[float, ...], str] = {}
    out = []
    for b in members:
        spot = tuple(float(v) for v in points[b])
        a = first.setdefault(spot, b)
        if a != b and (a, b) != (members[0], members[1]):
            out.append((a, b))
    return out


def _read_links(
    ctx: SceneContext, data: Mapping[str, Any], points: Mapping[str, np.ndarray]
) -> tuple[str, dict[str, Link]]:
    """ground and links: name -> the points it carries (ground first)."""
    ground = data.get('ground', 'ground')
    ctx.name('ground', ground)
    links_raw = ctx.mapping('links', data.get('links'))
    links: dict[str, Link] = {}
    if ground not in links_raw:
        ctx.fail('links', f'must contain the ground link {ground!r}', sorted(links_raw, key=str))
    # ground first: it is the parent of every joint it takes part in
    for lname in [ground] + [n for n in links_raw if n != ground]:
        members = links_raw[lname]
        key = f'links.{lname}'
        ctx.name(key, lname)
        if isinstance(members, str) or not isinstance(members, (list, tuple)) or not members:
            ctx.fail(key, 'must be a non-empty list of point names', members)
        for p in members:
            if not ctx.known(p, points):
                ctx.fail(key, f'unknown point {echo(p)}', p)
        if len(set(members)) != len(members):
            ctx.fail(key, 'lists a point twice', members)
        # a link's angle is the direction of its first -> second point (its axis): two points
        # on one spot give it none to solve for or report
        # two points of a rigid link on one spot (a plate drawn degenerate) are one point
        same = _coinciding(members, points)
        if same:
            a, b = same[0]
            ctx.fail(
                key,
                f'its points {a} and {b} coincide in the reference pose (at '
                f'{points[a].tolist()}): two points of one rigid link are one point; draw '
                'them apart or give the point once',
                list(members),
            )
        if len(members) >= 2 and np.array_equal(points[members[0]], points[members[1]]):
            ctx.fail(
                key,
                f'its first two points {members[0]} and {members[1]} coincide in the '
                f'reference pose (at {points[members[0]].tolist()}), so its axis (first '
                '-> second point) is undefined; list two distinct points first',
                list(members),
            )
        links[lname] = _make_link(lname, tuple(members), points)

    return ground, links


def _stem_name(stem: str) -> str:
    """A scene file's stem as the mechanism's default name: every character that is not a
    letter, digit or _ as _, and ``scene_`` before one that does not start with a letter
    (`four_bar.v2.yaml` is four_bar_v2, `4bar.yaml` scene_4bar)."""
    name = re.sub(r'[^A-Za-z0-9_]', '_', stem)
    return name if NAME_RE.match(name) else f'scene_{name}'


def _revolute_joints(
    ctx: SceneContext,
    points: Mapping[str, np.ndarray],
    links: Mapping[str, Link],
    prismatic_keys: Mapping[str, str],
) -> list[RevoluteJoint]:
    """A revolute joint wherever links share a point (the first link listed is the parent);
    ``prismatic_keys``: the prismatic joints' names -> their keys in the file."""

    revolutes: list[RevoluteJoint] = []
    used_names: set[str] = set(prismatic_keys)
    owners_of: dict[str, list[str]] = {}  # one pass over the links, not one per point
    for n, l in links.items():
        for p in l.points:
            owners_of.setdefault(p, []).append(n)
    for pname in points:
        owners = owners_of.get(pname, [])
        if not owners:
            ctx.fail(f'points.{pname}', 'is on no link', pname, has_value=False)
        for child in owners[1:]:
            jname = pname if len(owners) == 2 else f'{pname}_{child}'
            pin = f'the pin at point {pname!r} between links {owners[0]!r} and {child!r}'
            if jname in prismatic_keys:  # the prismatic was named by the file: name its key
                ctx.fail(
                    prismatic_keys[jname],
                    f'is also the name of a revolute joint, {pin}; give it another name',
                    jname,
                )
            if jname in used_names:
                ctx.fail(
                    f'points.{pname}', f'joint name {jname!r} clashes with another joint', jname
                )
            used_names.add(jname)
            revolutes.append(RevoluteJoint(jname, pname, owners[0], child))
    # pairs of links sharing a point, from the owners (not every pair of links)
    order = {n: i for i, n in enumerate(links)}
    shared_by: dict[tuple[str, str], set[str]] = {}
    for pname, owners in owners_of.items():
        for i, a in enumerate(owners):
            for b in owners[i + 1 :]:
                shared_by.setdefault((a, b), set()).add(pname)
    for a, b in sorted(shared_by, key=lambda ab: (order[ab[0]], order[ab[1]])):
        shared = shared_by[(a, b)]
        if len(shared) >= 2:
            ctx.fail(
                f'links.{b}',
                f'shares points {sorted(shared)} with link {a!r}; two '
                'links sharing two points are one rigid link',
                sorted(shared),
            )

    return revolutes


def _read_outputs(
    ctx: SceneContext,
    data: Mapping[str, Any],
    points: Mapping[str, np.ndarray],
    ground: str,
    links: Mapping[str, Link],
) -> tuple[str, ...]:
    """outputs: the published points (default: the coupler points)."""
    outputs_raw = data.get('outputs')
    if outputs_raw is None:
        # default: coupler points, i.e. points carried by exactly one moving link
        count: dict[str, int] = {}  # links carrying each point (one pass over the links)
        for link in links.values():
            for p in link.points:
                count[p] = count.get(p, 0) + 1
        on_ground = set(links[ground].points)
        outputs = tuple(p for p in points if count.get(p, 0) == 1 and p not in on_ground)
    else:
        if not isinstance(outputs_raw, list):
            ctx.fail('outputs', 'must be a list of point names', outputs_raw)
        listed: set[str] = set()
        for p in outputs_raw:
            if not ctx.known(p, points):
                ctx.fail('outputs', f'unknown point {echo(p)}', p)
            if p in listed:  # it would be published twice, under one name
                ctx.fail('outputs', f'lists point {p!r} twice; list each point once', outputs_raw)
            listed.add(p)
        outputs = tuple(outputs_raw)

    return outputs


def _check_one_point_links(
    ctx: SceneContext,
    ground: str,
    links: Mapping[str, Link],
    prismatics: Mapping[str, PrismaticJoint],
) -> None:
    for lname, link in links.items():
        if (
            lname != ground
            and len(link.points) == 1
            and not any(lname in (pj.guide, pj.slider) for pj in prismatics.values())
        ):
            ctx.fail(
                f'links.{lname}',
                'a one-point link must be a slider or a guide; '
                'otherwise its orientation is undefined',
                list(link.points),
            )


def _make_link(name: str, members: tuple[str, ...], points: Mapping[str, np.ndarray]) -> Link:
    if len(members) >= 2:
        v = points[members[1]] - points[members[0]]
        return Link(name, members, angle_ref=math.atan2(v[1], v[0]), axis=(members[0], members[1]))
    return Link(name, members, angle_ref=0.0)


def _length_scale(
    points: Mapping[str, np.ndarray],
    links: Mapping[str, Link],
    prismatics: Mapping[str, PrismaticJoint],
) -> float:
    """The largest distance between two points of one link (or a slider's reference throw)."""
    best = 0.0
    for link in links.values():
        if len(link.points) < 2:
            continue
        xy = np.array([points[p] for p in link.points], float)  # every pair at once
        best = max(
            best, float(np.hypot(*(xy[:, None, :] - xy[None, :, :]).transpose(2, 0, 1)).max())
        )
    for pj in prismatics.values():
        best = max(best, abs(pj.ref_value))
    if best == 0.0:
        best = max((float(np.hypot(*p)) for p in points.values()), default=1.0) or 1.0
    return best


def _check_reference_limits(
    ctx: SceneContext, mech: Mechanism, form: SceneForm, data: Mapping[str, Any]
) -> None:
    """The reference pose must be one the actuators can reach: it is the node's first state and
    it chooses the assembly mode. An actuator whose reference value is outside its own limits
    is refused, naming the key and both."""
    for name, act in mech.actuators.items():
        if act.min is None and act.max is None:
            continue
        value = reference_value(mech, act)
        bad = limit_violation(name, value, act.min, act.max, act.unit, act.periodic)
        if bad is None:
            continue
        if form is not SceneForm.GENERAL:
            key = f'{form.value}.input'
        elif name in (data.get('cylinders') or {}):
            key = f'cylinders.{name}'
        else:
            key = f'actuators.{name}'
        ctx.fail(
            key,
            f"the reference pose is outside this actuator's own limits ({bad}); the "
            'reference pose is the first state and chooses the assembly mode: draw it within '
            'the limits, or widen them',
            has_value=False,
        )
