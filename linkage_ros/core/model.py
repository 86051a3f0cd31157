"""Scene / mechanism model.

A mechanism is described the way the graphical ("tracing paper") method sees it: named points
with coordinates in one reference pose; links as rigid sets of those points; revolute joints where
links share a point; prismatic joints (a slider point on a line fixed in a guide link); actuators
that are an angle (crank) or a slide (a prismatic joint's throw, e.g. a hydraulic cylinder's
pin-to-pin length). Link geometry and the default assembly mode come from the reference pose.

Shortcut forms (``four_bar``, ``slider_crank``) compile into the same general form, so one
validator serves every scene. See docs/SCENES.md for the file format.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .errors import SceneError

NAME_RE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
SOLVERS = ('auto', 'closed_form', 'newton')


@dataclass(frozen=True)
class Link:
    """A rigid body: the named points it carries, in reference-pose coordinates.

    Its reported angle is the direction of ``axis`` (a point pair, counter-clockwise from +x, rad);
    by default the first two points (theta2 = direction O2->A for a crank). ``angle_ref`` is that
    direction in the reference pose.
    """

    name: str
    points: tuple[str, ...]
    angle_ref: float = 0.0
    axis: tuple[str, str] | None = None


@dataclass(frozen=True)
class RevoluteJoint:
    """Links ``parent`` and ``child`` share ``point``; the joint value is the child's angle minus
    the parent's angle (rad), each link's angle being the direction of its axis (first -> second
    point), so a URDF with each link frame on its axis reproduces the pose."""

    name: str
    point: str
    parent: str
    child: str


@dataclass(frozen=True)
class PrismaticJoint:
    """Point ``point`` of link ``slider`` slides on a line fixed in link ``guide``.

    The line passes through the point's reference position with unit ``direction`` (reference
    pose); the slider keeps its orientation relative to the guide. The joint value is the signed
    distance (m) along ``direction`` from ``origin`` (a reference-pose position fixed in the guide).
    """

    name: str
    guide: str
    slider: str
    point: str
    direction: tuple[float, float]
    origin: tuple[float, float]
    ref_value: float


@dataclass(frozen=True)
class Actuator:
    """An input: ``kind`` 'angle' (rad) or 'slide' (m).

    angle: the direction of ``pivot`` -> ``toward`` on ``link`` measured counter-clockwise from
    the reported direction of ``reference`` (from +x when the reference is the ground link).
    slide: the value of prismatic joint ``joint`` (a cylinder's pin-to-pin length).
    """

    name: str
    kind: str
    link: str | None = None
    reference: str | None = None
    pivot: str | None = None
    toward: str | None = None
    joint: str | None = None
    min: float | None = None
    max: float | None = None
    cylinder: bool = False


@dataclass
class Mechanism:
    name: str
    points: dict[str, np.ndarray]
    links: dict[str, Link]
    ground: str
    revolutes: list[RevoluteJoint]
    prismatics: dict[str, PrismaticJoint]
    actuators: dict[str, Actuator]
    outputs: tuple[str, ...]
    frame_id: str = 'world'
    solver: str = 'auto'
    source: str = '<scene>'
    length_scale: float = 1.0
    form: str = 'general'
    shortcut: dict[str, Any] = field(default_factory=dict)
    #: lengths the scene states (m), by (link, point, point): used exactly wherever the solver
    #: needs that distance, instead of the distance of the drawn reference coordinates (which
    #: is the given length only to within rounding)
    dimensions: dict[tuple[str, str, str], float] = field(default_factory=dict)

    def distance(self, link: str, p: str, q: str) -> float | None:
        """The stated length between points p and q of ``link``, or None."""
        d = self.dimensions.get((link, p, q))
        return self.dimensions.get((link, q, p)) if d is None else d

    # ---- derived views -------------------------------------------------------------------
    @property
    def moving_links(self) -> list[str]:
        return [n for n in self.links if n != self.ground]

    @property
    def joint_names(self) -> list[str]:
        return [j.name for j in self.revolutes] + list(self.prismatics)

    def links_of_point(self, point: str) -> list[str]:
        return [n for n, l in self.links.items() if point in l.points]

    @property
    def dof(self) -> int:
        """Kutzbach mobility 3(n - 1) - 2j (revolute and prismatic pairs count as one each)."""
        return 3 * (len(self.links) - 1) - 2 * (len(self.revolutes) + len(self.prismatics))

    def describe(self) -> dict[str, Any]:
        return {
            'name': self.name,
            'links': {n: list(l.points) for n, l in self.links.items()},
            'joints': {
                j.name: {'type': 'revolute', 'point': j.point, 'parent': j.parent, 'child': j.child}
                for j in self.revolutes
            }
            | {
                p.name: {
                    'type': 'prismatic',
                    'guide': p.guide,
                    'slider': p.slider,
                    'point': p.point,
                }
                for p in self.prismatics.values()
            },
            'actuators': {a.name: a.kind for a in self.actuators.values()},
            'n_links': len(self.links),
            'n_joints': len(self.revolutes) + len(self.prismatics),
            'dof': self.dof,
        }


@dataclass
class Scene:
    """A scene file: one mechanism plus the frame it is published in and the default solver."""

    mechanism: Mechanism
    path: str | None = None

    @property
    def frame_id(self) -> str:
        return self.mechanism.frame_id

    @classmethod
    def from_yaml(cls, path: str | Path) -> Scene:
        path = str(path)
        try:
            with open(path, encoding='utf-8') as fh:
                data = yaml.load(fh, Loader=_UniqueKeyLoader)
        except FileNotFoundError:
            raise SceneError('scene file not found', file=path) from None
        except UnicodeDecodeError:
            raise SceneError(
                f'not UTF-8 text ({_first_bad_utf8(path)}); save it as UTF-8', file=path
            ) from None
        except OSError as exc:
            raise SceneError(f'cannot read scene file: {exc.strerror}', file=path) from None
        except yaml.YAMLError as exc:
            mark = getattr(exc, 'problem_mark', None)
            where = f' at line {mark.line + 1}, column {mark.column + 1}' if mark else ''
            raise SceneError(
                f'invalid YAML{where}: {getattr(exc, "problem", exc)}', file=path
            ) from None
        return cls(mechanism=build_mechanism(data, source=path), path=path)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], source: str = '<scene>') -> Scene:
        return cls(mechanism=build_mechanism(data, source=source), path=None)


def _first_bad_utf8(path: str) -> str:
    """Where a file stops being UTF-8: the reader's error counts from the start of its buffer,
    not of the file."""
    try:
        raw = Path(path).read_bytes()
        raw.decode('utf-8')
    except UnicodeDecodeError as exc:
        line = raw.count(b'\n', 0, exc.start) + 1
        return f'byte {raw[exc.start : exc.start + 1]!r} on line {line} cannot be decoded'
    except OSError:
        pass
    return 'it cannot be decoded'


class _UniqueKeyLoader(yaml.SafeLoader):
    """safe_load that refuses a key given twice in one mapping (YAML's last-one-wins would build
    a different mechanism than the file shows) and reads 1e-3 as a number (YAML 1.2), not as the
    string YAML 1.1 makes of an exponent without a dot."""

    def construct_mapping(self, node, deep=False):
        seen = {}
        for key_node, _ in node.value:
            # deep: a list key is filled in only later otherwise, and the message shows it
            key = self.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError:  # `? [a, b]` or `? {a: 1}`: a list or mapping as a key
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f'a mapping key must be a name or number, not {key!r}',
                    key_node.start_mark,
                ) from None
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None,
                    None,
                    f'duplicate key {key!r} (first at line {seen[key] + 1})',
                    key_node.start_mark,
                )
            seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


# YAML 1.1 floats need a dot and a signed exponent (1.0e+3); also take 1e-3, 1E5, 2.5e3, .5e3.
_UniqueKeyLoader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'),
)


# ---- validation helpers ----------------------------------------------------------------------


class _Ctx:
    def __init__(self, source: str):
        self.source = source

    def fail(self, key: str, message: str, value: object = None, has_value: bool = True):
        raise SceneError(message, file=self.source, key=key, value=value, has_value=has_value)

    def number(self, key: str, value: object, *, positive: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, 'must be a number', value)
        v = float(value)
        if not math.isfinite(v):
            self.fail(key, 'must be finite', value)
        if positive and not v > 0:
            self.fail(key, 'must be > 0', value)
        return v

    def xy(self, key: str, value: object) -> np.ndarray:
        if not isinstance(value, (list, tuple)) or len(value) != 2:
            self.fail(key, 'must be a list [x, y] of two numbers (m)', value)
        return np.array([self.number(f'{key}[{i}]', v) for i, v in enumerate(value)])

    def name(self, key: str, value: object) -> str:
        if not isinstance(value, str) or not NAME_RE.match(value):
            self.fail(key, 'must be a name of letters, digits and _ starting with a letter', value)
        return value

    @staticmethod
    def known(value: object, names) -> bool:
        """``value in names`` for a name; False (not TypeError) for a list or mapping."""
        return isinstance(value, str) and value in names

    def mapping(self, key: str, value: object) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            self.fail(key, 'must be a mapping', value)
        return value

    def only(self, key: str, data: Mapping[str, Any], allowed: set[str]):
        for k in data:
            if k not in allowed:
                self.fail(
                    f'{key}.{k}' if key else str(k),
                    f'unknown key; expected one of {sorted(allowed)}',
                    has_value=False,
                )


TOP_KEYS = {
    'name',
    'frame_id',
    'solver',
    'four_bar',
    'slider_crank',
    'points',
    'links',
    'ground',
    'sliders',
    'cylinders',
    'actuators',
    'outputs',
}


def build_mechanism(data: Any, source: str = '<scene>') -> Mechanism:
    """Validate a scene mapping (general or shortcut form) and build the Mechanism."""
    ctx = _Ctx(source)
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
    if solver not in SOLVERS:
        ctx.fail('solver', f'must be one of {list(SOLVERS)}', solver)
    form = forms[0]
    if form != 'points':
        clash = [k for k in ('links', 'ground', 'sliders', 'cylinders', 'actuators') if k in data]
        if clash:
            ctx.fail(
                clash[0],
                f'is a general-form key; it cannot be combined with the {form} '
                'shortcut (use the general form instead)',
                has_value=False,
            )
    shortcut: dict[str, Any] = {}
    if form == 'four_bar':
        general, shortcut = _four_bar_to_general(ctx, data)
    elif form == 'slider_crank':
        general, shortcut = _slider_crank_to_general(ctx, data)
    else:
        general = dict(data)
    if form != 'points' and 'outputs' in data:
        general['outputs'] = data['outputs']  # a shortcut may name its published points
    default_name = (
        Path(source).stem if source != '<scene>' else ('mechanism' if form == 'points' else form)
    )
    name = ctx.name('name', data.get('name', default_name))
    mech = _build_general(ctx, general, name=name, frame_id=frame_id, solver=solver)
    mech.form = form if form != 'points' else 'general'
    mech.shortcut = shortcut
    if form == 'four_bar':
        mech.dimensions = {
            ('crank', 'O2', 'A'): shortcut['crank'],
            ('coupler', 'A', 'B'): shortcut['coupler'],
            ('rocker', 'O4', 'B'): shortcut['rocker'],
        }
    elif form == 'slider_crank':
        mech.dimensions = {
            ('crank', 'O2', 'A'): shortcut['crank'],
            ('rod', 'A', 'B'): shortcut['rod'],
        }
    return mech


def _build_general(
    ctx: _Ctx, data: Mapping[str, Any], *, name: str, frame_id: str, solver: str
) -> Mechanism:
    pts_raw = ctx.mapping('points', data.get('points'))
    if not pts_raw:
        ctx.fail('points', 'must name at least two points', pts_raw)
    points: dict[str, np.ndarray] = {}
    for pname, xy in pts_raw.items():
        ctx.name(f'points.{pname}', pname)
        points[pname] = ctx.xy(f'points.{pname}', xy)

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
                ctx.fail(key, f'unknown point {p!r}', p)
        if len(set(members)) != len(members):
            ctx.fail(key, 'lists a point twice', members)
        # a link's angle is the direction of its first -> second point (its axis): two points
        # on one spot give it none to solve for or report
        if len(members) >= 2 and np.array_equal(points[members[0]], points[members[1]]):
            ctx.fail(
                key,
                f'its first two points {members[0]} and {members[1]} coincide in the '
                f'reference pose (at {points[members[0]].tolist()}), so its axis (first '
                '-> second point) is undefined; list two distinct points first',
                list(members),
            )
        links[lname] = _make_link(lname, tuple(members), points)

    prismatics: dict[str, PrismaticJoint] = {}
    actuators: dict[str, Actuator] = {}

    # cylinders: barrel pinned at `from`, rod pinned at `to`, a prismatic pair between them
    cyl_raw = data.get('cylinders') or {}
    ctx.mapping('cylinders', cyl_raw)
    for cname, spec in cyl_raw.items():
        key = f'cylinders.{cname}'
        ctx.name(key, cname)
        spec = ctx.mapping(key, spec)
        ctx.only(key, spec, {'from', 'to', 'min', 'max'})
        a, b = spec.get('from'), spec.get('to')
        for k, p in (('from', a), ('to', b)):
            if not ctx.known(p, points):
                ctx.fail(f'{key}.{k}', 'must name a point', p)
        axis = points[b] - points[a]
        length = float(np.hypot(*axis))
        if not length > 0:
            ctx.fail(key, 'pins `from` and `to` coincide in the reference pose', [a, b])
        barrel, rod = f'{cname}_barrel', f'{cname}_rod'
        for ln in (barrel, rod):
            if ln in links:
                ctx.fail(key, f'link name {ln!r} (made for the cylinder) is already used', ln)
        ang = math.atan2(axis[1], axis[0])
        links[barrel] = Link(barrel, (a,), angle_ref=ang)
        links[rod] = Link(rod, (b,), angle_ref=ang)
        u = axis / length
        prismatics[cname] = PrismaticJoint(
            cname,
            barrel,
            rod,
            b,
            (float(u[0]), float(u[1])),
            (float(points[a][0]), float(points[a][1])),
            length,
        )
        lo, hi = _limits(ctx, key, spec)
        if lo is not None and lo <= 0:
            ctx.fail(f'{key}.min', 'a cylinder length must be > 0', lo)
        actuators[cname] = Actuator(cname, 'slide', joint=cname, min=lo, max=hi, cylinder=True)

    sliders_raw = data.get('sliders') or []
    if not isinstance(sliders_raw, list):
        ctx.fail('sliders', 'must be a list of prismatic joints', sliders_raw)
    for i, spec in enumerate(sliders_raw):
        key = f'sliders[{i}]'
        spec = ctx.mapping(key, spec)
        ctx.only(key, spec, {'name', 'guide', 'slider', 'point', 'direction', 'origin'})
        jname = ctx.name(f'{key}.name', spec.get('name'))
        key = f'sliders.{jname}'
        if jname in prismatics:
            ctx.fail(key, 'duplicate prismatic joint name', jname)
        guide, slider, point = spec.get('guide'), spec.get('slider'), spec.get('point')
        for k, v in (('guide', guide), ('slider', slider)):
            if not ctx.known(v, links):
                ctx.fail(f'{key}.{k}', 'must name a link', v)
        if guide == slider:
            ctx.fail(f'{key}.slider', 'must differ from the guide link', slider)
        if not ctx.known(point, links[slider].points):
            ctx.fail(f'{key}.point', f'must be a point of the slider link {slider!r}', point)
        d = spec.get('direction', 0.0)
        if isinstance(d, (list, tuple)):
            dv = ctx.xy(f'{key}.direction', d)
        else:
            ang = ctx.number(f'{key}.direction', d)
            dv = np.array([math.cos(ang), math.sin(ang)])
        n = float(np.hypot(*dv))
        if not n > 0:
            ctx.fail(f'{key}.direction', 'must be a non-zero vector', d)
        dv = dv / n
        o = spec.get('origin', point)
        if isinstance(o, str):
            if not ctx.known(o, points):
                ctx.fail(f'{key}.origin', 'must name a point or be [x, y]', o)
            ov = points[o]
        else:
            ov = ctx.xy(f'{key}.origin', o)
        ref_value = float(np.dot(points[point] - ov, dv))
        prismatics[jname] = PrismaticJoint(
            jname,
            guide,
            slider,
            point,
            (float(dv[0]), float(dv[1])),
            (float(ov[0]), float(ov[1])),
            ref_value,
        )

    # revolute joints where links share a point (the first link listed is the parent)
    revolutes: list[RevoluteJoint] = []
    used_names: set[str] = set(prismatics)
    for pname in points:
        owners = [n for n, l in links.items() if pname in l.points]
        if not owners:
            ctx.fail(f'points.{pname}', 'is on no link', pname, has_value=False)
        for child in owners[1:]:
            jname = pname if len(owners) == 2 else f'{pname}_{child}'
            if jname in used_names:
                ctx.fail(
                    f'points.{pname}', f'joint name {jname!r} clashes with another joint', jname
                )
            used_names.add(jname)
            revolutes.append(RevoluteJoint(jname, pname, owners[0], child))
    names = list(links)
    for i, a in enumerate(names):
        for b in names[i + 1 :]:
            shared = set(links[a].points) & set(links[b].points)
            if len(shared) >= 2:
                ctx.fail(
                    f'links.{b}',
                    f'shares points {sorted(shared)} with link {a!r}; two '
                    'links sharing two points are one rigid link',
                    sorted(shared),
                )

    act_raw = data.get('actuators') or {}
    ctx.mapping('actuators', act_raw)
    for aname, spec in act_raw.items():
        key = f'actuators.{aname}'
        ctx.name(key, aname)
        if aname in actuators:
            ctx.fail(key, 'duplicate actuator name (a cylinder already has it)', aname)
        spec = ctx.mapping(key, spec)
        kind = spec.get('type')
        lo, hi = _limits(ctx, key, spec)
        if kind == 'angle':
            ctx.only(key, spec, {'type', 'link', 'pivot', 'toward', 'relative_to', 'min', 'max'})
            link = spec.get('link')
            if not ctx.known(link, links) or link == ground:
                ctx.fail(f'{key}.link', 'must name a moving link', link)
            ref = spec.get('relative_to', ground)
            if not ctx.known(ref, links) or ref == link:
                ctx.fail(f'{key}.relative_to', 'must name another link', ref)
            pivot = spec.get('pivot')
            if not ctx.known(pivot, links[link].points):
                ctx.fail(f'{key}.pivot', f'must be a point of link {link!r}', pivot)
            toward = spec.get('toward')
            if toward is None:
                others = [p for p in links[link].points if p != pivot]
                if not others:
                    ctx.fail(f'{key}.toward', f'link {link!r} has one point: name `toward`', None)
                toward = others[0]
            if not ctx.known(toward, links[link].points) or toward == pivot:
                ctx.fail(f'{key}.toward', f'must be another point of link {link!r}', toward)
            actuators[aname] = Actuator(
                aname, 'angle', link=link, reference=ref, pivot=pivot, toward=toward, min=lo, max=hi
            )
        elif kind == 'slide':
            ctx.only(key, spec, {'type', 'joint', 'min', 'max'})
            joint = spec.get('joint')
            if not ctx.known(joint, prismatics):
                ctx.fail(f'{key}.joint', 'must name a prismatic joint (sliders)', joint)
            actuators[aname] = Actuator(aname, 'slide', joint=joint, min=lo, max=hi)
        else:
            ctx.fail(f'{key}.type', "must be 'angle' or 'slide'", kind)

    outputs_raw = data.get('outputs')
    if outputs_raw is None:
        # default: coupler points, i.e. points carried by exactly one moving link
        outputs = tuple(
            p
            for p in points
            if len([n for n in links if p in links[n].points]) == 1
            and ground not in [n for n in links if p in links[n].points]
        )
    else:
        if not isinstance(outputs_raw, list):
            ctx.fail('outputs', 'must be a list of point names', outputs_raw)
        for p in outputs_raw:
            if not ctx.known(p, points):
                ctx.fail('outputs', f'unknown point {p!r}', p)
        outputs = tuple(outputs_raw)

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

    scale = _length_scale(points, links, prismatics)
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
    if not actuators:
        ctx.fail('actuators', 'the mechanism needs at least one actuator (or cylinder)', None)
    if mech.dof != len(actuators):
        ctx.fail(
            'actuators',
            f'the mechanism has {mech.dof} degree(s) of freedom (Kutzbach '
            f'3(n-1)-2j with n={len(links)} links, j={len(revolutes) + len(prismatics)} '
            f'joints) but {len(actuators)} actuator(s)',
            sorted(actuators),
        )
    return mech


def _limits(ctx: _Ctx, key: str, spec: Mapping[str, Any]) -> tuple[float | None, float | None]:
    lo = spec.get('min')
    hi = spec.get('max')
    lo = None if lo is None else ctx.number(f'{key}.min', lo)
    hi = None if hi is None else ctx.number(f'{key}.max', hi)
    if lo is not None and hi is not None and not lo < hi:
        ctx.fail(f'{key}.max', f'must be greater than min ({lo})', hi)
    return lo, hi


def _make_link(name: str, members: tuple[str, ...], points: Mapping[str, np.ndarray]) -> Link:
    if len(members) >= 2:
        v = points[members[1]] - points[members[0]]
        return Link(name, members, angle_ref=math.atan2(v[1], v[0]), axis=(members[0], members[1]))
    return Link(name, members, angle_ref=0.0)


def _length_scale(points, links, prismatics) -> float:
    """The largest distance between two points of one link (or a slider's reference throw)."""
    best = 0.0
    for link in links.values():
        pts = [points[p] for p in link.points]
        for i in range(len(pts)):
            for j in range(i + 1, len(pts)):
                best = max(best, float(np.hypot(*(pts[i] - pts[j]))))
    for pj in prismatics.values():
        best = max(best, abs(pj.ref_value))
    if best == 0.0:
        best = max((float(np.hypot(*p)) for p in points.values()), default=1.0) or 1.0
    return best


# ---- shortcut forms --------------------------------------------------------------------------


def _branch(ctx: _Ctx, key: str, value: object) -> int:
    if isinstance(value, bool):  # True == 1: `branch: true` must not pass for +1
        ctx.fail(key, "must be +1 or -1 (or '+' / '-')", value)
    if value in (1, '+', '+1'):
        return 1
    if value in (-1, '-', '-1'):
        return -1
    ctx.fail(key, "must be +1 or -1 (or '+' / '-')", value)
    return 1


def _crank_actuator(ctx: _Ctx, key: str, spec: Mapping[str, Any]) -> dict[str, Any]:
    """The shortcut forms' crank: the angle of O2 -> A, with optional crank_limits."""
    crank = {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'A'}
    if 'crank_limits' in spec:
        lim = ctx.mapping(f'{key}.crank_limits', spec['crank_limits'])
        ctx.only(f'{key}.crank_limits', lim, {'min', 'max'})
        crank.update({k: lim[k] for k in ('min', 'max') if k in lim})
    return crank


def _reference_input(
    ctx: _Ctx, key: str, spec: Mapping[str, Any], start: float, assemble, lengths, intervals
):
    """The reference crank angle: ``input`` if given (it must assemble), else the assembling
    angle nearest ``start`` (60 degrees above the ground line). ``assemble(theta)`` returns the
    reference points or None; ``intervals()`` lists the (lo, hi) crank angles that assemble
    (exact, from the closure condition)."""
    if 'input' in spec:
        theta = ctx.number(f'{key}.input', spec['input'])
        pts = assemble(theta)
        if pts is None:
            ctx.fail(f'{key}.input', 'the mechanism does not assemble at this crank angle', theta)
        return pts
    steps = np.repeat(np.linspace(0.01, np.pi, 315), 2) * np.tile([1, -1], 315)
    for theta in start + np.concatenate([[0.0], steps]):
        pts = assemble(float(theta))
        if pts is not None:
            return pts
    # The 0.01 rad grid misses a range narrower than its step (a short rod or coupler): try the
    # middle of each exact range, nearest ``start`` first (the middle is furthest from a toggle).
    mids = [0.5 * (lo + hi) for lo, hi in intervals()]
    for theta in sorted(mids, key=lambda t: abs(math.remainder(t - start, 2 * math.pi))):
        pts = assemble(theta)
        if pts is not None:
            return pts
    ctx.fail(key, 'these lengths do not assemble at any crank angle', lengths)


def _four_bar_to_general(ctx: _Ctx, data: Mapping[str, Any]):
    from .dyads import circle_circle

    fb = ctx.mapping('four_bar', data['four_bar'])
    ctx.only(
        'four_bar',
        fb,
        {
            'ground',
            'crank',
            'coupler',
            'rocker',
            'ground_angle',
            'pivots',
            'coupler_point',
            'input',
            'branch',
            'crank_limits',
        },
    )
    l2 = ctx.number('four_bar.crank', fb.get('crank'), positive=True)
    l3 = ctx.number('four_bar.coupler', fb.get('coupler'), positive=True)
    l4 = ctx.number('four_bar.rocker', fb.get('rocker'), positive=True)
    if 'pivots' in fb:
        piv = ctx.mapping('four_bar.pivots', fb['pivots'])
        ctx.only('four_bar.pivots', piv, {'O2', 'O4'})
        o2 = ctx.xy('four_bar.pivots.O2', piv.get('O2'))
        o4 = ctx.xy('four_bar.pivots.O4', piv.get('O4'))
        l1 = float(np.hypot(*(o4 - o2)))
        if not l1 > 0:
            ctx.fail('four_bar.pivots', 'O2 and O4 coincide', fb['pivots'])
        if 'ground' in fb:
            g = ctx.number('four_bar.ground', fb['ground'], positive=True)
            if abs(g - l1) > 1e-9 * max(g, l1):
                ctx.fail('four_bar.ground', f'disagrees with |O2O4| = {l1!r} from pivots', g)
        if 'ground_angle' in fb:
            ctx.fail(
                'four_bar.ground_angle', 'give pivots or ground_angle, not both', fb['ground_angle']
            )
        gang = math.atan2(*(o4 - o2)[::-1])
    else:
        l1 = ctx.number('four_bar.ground', fb.get('ground'), positive=True)
        gang = ctx.number('four_bar.ground_angle', fb.get('ground_angle', 0.0))
        o2 = np.zeros(2)
        o4 = o2 + l1 * np.array([math.cos(gang), math.sin(gang)])
    branch = _branch(ctx, 'four_bar.branch', fb.get('branch', 1))

    def assemble(theta):
        a = o2 + l2 * np.array([math.cos(theta), math.sin(theta)])
        b, _, ok, _, _ = circle_circle(a, l3, o4, l4, branch)
        return (a, b) if ok and np.hypot(*(b - a)) > 0 else None

    def intervals():
        from .analysis import fourbar_input_intervals

        try:
            ivs = fourbar_input_intervals(l1, l2, l3, l4)
        except ValueError:  # assembles nowhere
            return []
        # None (turns fully) cannot reach here: the grid's first angle assembles
        return [] if ivs is None else [(gang + lo, gang + hi) for lo, hi in ivs]

    a, b = _reference_input(
        ctx, 'four_bar', fb, gang + np.pi / 3, assemble, [l1, l2, l3, l4], intervals
    )
    points = {'O2': o2, 'A': a, 'B': b, 'O4': o4}
    coupler = ['A', 'B']
    cp = fb.get('coupler_point')
    if cp is not None:
        cp = ctx.mapping('four_bar.coupler_point', cp)
        ctx.only('four_bar.coupler_point', cp, {'name', 'distance', 'angle'})
        pname = ctx.name('four_bar.coupler_point.name', cp.get('name', 'P'))
        if pname in points:
            ctx.fail('four_bar.coupler_point.name', 'clashes with O2, A, B or O4', pname)
        dist = ctx.number('four_bar.coupler_point.distance', cp.get('distance'))
        ang = ctx.number('four_bar.coupler_point.angle', cp.get('angle', 0.0))
        t3 = math.atan2(*(b - a)[::-1])
        points[pname] = a + dist * np.array([math.cos(t3 + ang), math.sin(t3 + ang)])
        coupler.append(pname)
    crank = _crank_actuator(ctx, 'four_bar', fb)
    general = {
        'points': {k: [float(v[0]), float(v[1])] for k, v in points.items()},
        'links': {
            'ground': ['O2', 'O4'],
            'crank': ['O2', 'A'],
            'coupler': coupler,
            'rocker': ['O4', 'B'],
        },
        'actuators': {'crank': crank},
        'outputs': coupler[2:],
    }
    return general, {
        'form': 'four_bar',
        'ground': l1,
        'crank': l2,
        'coupler': l3,
        'rocker': l4,
        'ground_angle': gang,
        'branch': branch,
    }


def _slider_crank_to_general(ctx: _Ctx, data: Mapping[str, Any]):
    sc = ctx.mapping('slider_crank', data['slider_crank'])
    ctx.only(
        'slider_crank',
        sc,
        {'crank', 'rod', 'offset', 'direction', 'input', 'branch', 'crank_limits'},
    )
    r = ctx.number('slider_crank.crank', sc.get('crank'), positive=True)
    rod = ctx.number('slider_crank.rod', sc.get('rod'), positive=True)
    e = ctx.number('slider_crank.offset', sc.get('offset', 0.0))
    dang = ctx.number('slider_crank.direction', sc.get('direction', 0.0))
    branch = _branch(ctx, 'slider_crank.branch', sc.get('branch', 1))
    d = np.array([math.cos(dang), math.sin(dang)])
    n = np.array([-d[1], d[0]])
    o2 = np.zeros(2)
    foot = o2 + e * n

    def assemble(theta):
        a = o2 + r * np.array([math.cos(theta), math.sin(theta)])
        dy = e - float(np.dot(a, n))
        if rod - abs(dy) < 0:
            return None
        # roots factor by factor: the product underflows for lengths near 1e-300
        x = float(np.dot(a, d)) + branch * math.sqrt(rod - abs(dy)) * math.sqrt(rod + abs(dy))
        return a, foot + x * d

    def intervals():
        # A's height over the line of stroke is r sin(phi), phi = theta - direction; the rod
        # reaches the line iff |e - r sin(phi)| <= rod
        lo, hi = max((e - rod) / r, -1.0), min((e + rod) / r, 1.0)
        if lo > hi:
            return []
        a0, a1 = math.asin(lo), math.asin(hi)
        return [(dang + a0, dang + a1), (dang + math.pi - a1, dang + math.pi - a0)]

    a, b = _reference_input(
        ctx, 'slider_crank', sc, dang + np.pi / 3, assemble, [r, rod, e], intervals
    )
    crank = _crank_actuator(ctx, 'slider_crank', sc)
    general = {
        'points': {
            'O2': [0.0, 0.0],
            'A': [float(a[0]), float(a[1])],
            'B': [float(b[0]), float(b[1])],
        },
        'links': {'ground': ['O2'], 'crank': ['O2', 'A'], 'rod': ['A', 'B'], 'slider': ['B']},
        'sliders': [
            {
                'name': 'slider',
                'guide': 'ground',
                'slider': 'slider',
                'point': 'B',
                'direction': [float(d[0]), float(d[1])],
                'origin': [float(foot[0]), float(foot[1])],
            }
        ],
        'actuators': {'crank': crank},
        'outputs': [],
    }
    return general, {
        'form': 'slider_crank',
        'crank': r,
        'rod': rod,
        'offset': e,
        'direction': dang,
        'branch': branch,
    }
