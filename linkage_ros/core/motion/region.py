"""Reachable regions of a point: sampled, hulled, and measured."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from enum import Enum
from typing import Any

import numpy as np

from ..brent import brent_minimum
from ..model import AngleActuator, Mechanism
from ..solver import SolveMode, Solver
from .common import point_key, reference_point, reference_scalar
from .ranges import actuator_range

# ---- reachable regions ------------------------------------------------------------------------


class Boundary(Enum):
    """How a reachable region's boundary was found (the report's ``method``)."""

    POINT = 'point'  # the point does not move
    PATH = 'path'  # one actuator: the path itself
    EXTREME_ARCS = 'extreme_arcs'  # the closed-form extremes, joined in order
    CONCAVE_HULL = 'concave_hull'  # the cloud's concave hull


def _actuator_limits(mech: Mechanism, name: str, samples: int) -> tuple[float, float]:
    act = mech.actuators[name]
    if act.min is not None and act.max is not None:
        return float(act.min), float(act.max)
    info = actuator_range(mech, name, samples)
    x0 = info['reference']
    if isinstance(act, AngleActuator):
        if info['min'] is None:
            return x0 - math.pi, x0 + math.pi
        return float(info['min']), float(info['max'])
    lo = info['min'] if info['min'] is not None else x0 - mech.length_scale
    hi = info['max'] if info['max'] is not None else x0 + mech.length_scale
    return float(lo), float(hi)


def _moving_actuators(mech: Mechanism, point: str, solver: Solver) -> list[str]:
    ref = {a: reference_scalar(mech, a) for a in mech.actuators}
    base = solver.solve_batch({a: [v] for a, v in ref.items()})
    p0 = base.points[point][0]
    out = []
    for a, act in mech.actuators.items():
        d = 1e-4 if isinstance(act, AngleActuator) else 1e-4 * mech.length_scale
        moved = False
        for sgn in (1, -1):
            cols = {b: [v] for b, v in ref.items()}
            cols[a] = [ref[a] + sgn * d]
            r = solver.solve_batch(cols)
            if r.ok[0]:
                moved = float(np.hypot(*(r.points[point][0] - p0))) > 1e-9 * mech.length_scale
                break
        if moved:
            out.append(a)
    return out


def _polygon_area(poly: np.ndarray) -> float:
    return abs(_signed_area(poly))


def _signed_area(poly: np.ndarray) -> float:
    """The shoelace area of a closed polygon (first vertex not repeated), counter-clockwise
    positive."""
    if len(poly) < 3:
        return 0.0
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * (float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _arcs_area(boundary: np.ndarray, arcs: Sequence[np.ndarray]) -> float:
    """The area inside smooth arcs, each sampled at evenly spaced values of its sweep and
    joined end to end into ``boundary``: the shoelace area of the polygon through the samples
    (the chords: short by O(h^2) of the area) plus, per pair of samples, a third of their
    triangle: the area between a chord and the parabola through its two ends and the sample
    between them is 4/3 of that triangle (the tangent there is parallel to the chord), Simpson's
    rule on Green's integral, O(h^4). An arc of an odd sample count leaves its last chord as it
    is. Measured on the excavator's zone of K (four circular arcs, 160 samples each): the
    polygon 7.147223 m^2, this 7.1473047, the exact circular integral 7.14730469."""
    bulge = 0.0
    for pts in arcs:
        for k in range(0, len(pts) - 2, 2):
            d1, d2 = pts[k + 1] - pts[k], pts[k + 2] - pts[k]
            bulge += 0.5 * float(d1[0] * d2[1] - d1[1] * d2[0]) / 3.0
    return abs(_signed_area(boundary) + bulge)


Solve = Callable[[Mapping[str, np.ndarray]], tuple[np.ndarray, np.ndarray]]


def _arcs_extent(arcs: Sequence[Mapping[str, Any]], solve: Solve) -> list[list[float]]:
    """[[x min, x max], [y min, y max]] of the region inside the boundary arcs (each sampled at
    evenly spaced values of its sweep, the other actuator held): the extreme sample of each,
    refined where the extreme lies between samples by Brent's method in the sweep value between
    the samples either side, each point solved. The samples alone fall short by O(h^2) (the
    excavator's K: 3.995004 from 81 samples per arc, 3.9950847 from their parabola's vertex;
    the true largest x is 3.9950868)."""
    out = []
    for axis in (0, 1):
        ends = []
        for sign in (-1.0, 1.0):
            ends.append(sign * max(_arc_extreme(a, axis, sign, solve) for a in arcs))
        out.append(ends)
    return out


def _arc_extreme(arc: Mapping[str, Any], axis: int, sign: float, solve: Solve) -> float:
    """max of sign * (coordinate ``axis``) over one boundary arc (see _arcs_extent)."""
    fixed, _, held = arc['fixed']

    def point_at(x: float) -> np.ndarray | None:
        ok, at = solve({fixed: np.array([float(held)]), arc['sweep']: np.array([x])})
        return at[0] if ok[0] else None

    return _extreme_along(arc['inputs'], arc['points'], axis, sign, point_at)


def _path_extent(throws: Any, points: Any, actuator: str, solve: Solve) -> list[list[float]]:
    """[[x min, x max], [y min, y max]] of one actuator's path (sampled at ``throws``), each
    extreme refined as an arc's (_arcs_extent): the samples alone were 2.4e-4 m short on a
    Jansen leg's foot, printed to six digits (an outside scene author)."""

    def point_at(x: float) -> np.ndarray | None:
        ok, at = solve({actuator: np.array([x])})
        return at[0] if ok[0] else None

    return [
        [sign * _extreme_along(throws, points, axis, sign, point_at) for sign in (-1.0, 1.0)]
        for axis in (0, 1)
    ]


def _extreme_along(
    inputs: Any, points: Any, axis: int, sign: float, point_at: Callable[[float], Any]
) -> float:
    """max of sign * (coordinate ``axis``) along samples ``points`` at sweep values
    ``inputs`` (ascending), refined between the samples either side of the best by Brent's
    method on ``point_at`` (None: no assembly there)."""
    s = np.asarray(inputs, float)
    v = sign * np.asarray(points, float).reshape(-1, 2)[:, axis]
    k = int(np.argmax(v))
    best = float(v[k])
    if len(v) < 3:
        return best
    j = min(max(k, 1), len(v) - 2)  # (an extreme sample at an end: the bracket at that end)

    def below(x: float) -> float:  # minus sign * coordinate at sweep value x
        at = point_at(x)
        return -sign * float(at[axis]) if at is not None else math.inf

    lo, hi = sorted((float(s[j - 1]), float(s[j + 1])))
    _, f = brent_minimum(below, lo, hi, xatol=1e-15 * max(1.0, abs(lo), abs(hi)))
    return max(best, -f)


#: points and polygon edges per block of the point-against-edge tables: each table is at most
#: POINT_BLOCK x EDGE_BLOCK entries (2 MB of floats), whatever the cloud and the boundary (a
#: 401 x 401 throw grid against its 6400-vertex arcs took ~15 GB in one table each)
POINT_BLOCK = 1024
EDGE_BLOCK = 256


def points_in_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Even-odd rule: which of the (n, 2) points lie inside the closed polygon (m, 2)."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    poly = np.asarray(poly, float).reshape(-1, 2)
    crossings = np.zeros(pts.shape[0], np.int64)
    x1a, y1a = poly[:, 0], poly[:, 1]
    x2a, y2a = np.roll(x1a, -1), np.roll(y1a, -1)
    for i in range(0, pts.shape[0], POINT_BLOCK):
        x, y = pts[i : i + POINT_BLOCK, 0][:, None], pts[i : i + POINT_BLOCK, 1][:, None]
        for k in range(0, poly.shape[0], EDGE_BLOCK):
            edges = slice(k, k + EDGE_BLOCK)
            x1, y1 = x1a[edges][None, :], y1a[edges][None, :]
            x2, y2 = x2a[edges][None, :], y2a[edges][None, :]
            cond = (y1 > y) != (y2 > y)
            with np.errstate(divide='ignore', invalid='ignore'):
                xint = x1 + (y - y1) * (x2 - x1) / np.where(y2 != y1, y2 - y1, 1.0)
            crossings[i : i + POINT_BLOCK] += np.sum(cond & (x < xint), axis=1)
    inside: np.ndarray = (crossings % 2) == 1
    return inside


def distance_to_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each of the (n, 2) points to the polygon's edges."""
    pts = np.asarray(pts, float).reshape(-1, 2)
    a = np.asarray(poly, float).reshape(-1, 2)
    b = np.roll(a, -1, axis=0)
    ab = b - a
    L2 = np.sum(ab * ab, axis=1)
    best = np.full(pts.shape[0], np.inf)
    for i in range(0, pts.shape[0], POINT_BLOCK):
        block = pts[i : i + POINT_BLOCK]
        for k in range(0, a.shape[0], EDGE_BLOCK):
            aa, bb, ll = a[k : k + EDGE_BLOCK], ab[k : k + EDGE_BLOCK], L2[k : k + EDGE_BLOCK]
            ap = block[:, None, :] - aa[None, :, :]
            t = np.clip(np.sum(ap * bb[None], axis=2) / np.where(ll > 0, ll, 1.0)[None], 0.0, 1.0)
            d = ap - t[..., None] * bb[None]
            near = np.min(np.hypot(d[..., 0], d[..., 1]), axis=1)
            best[i : i + POINT_BLOCK] = np.minimum(best[i : i + POINT_BLOCK], near)
    return best


def _concave_hull(pts: np.ndarray, max_edge: float) -> np.ndarray:
    """Outer boundary (m, 2) of the alpha shape of ``pts``: the Delaunay triangles whose edges are
    all at most ``max_edge`` long, merged."""
    from scipy.spatial import Delaunay

    pts = np.unique(np.asarray(pts, float), axis=0)
    if pts.shape[0] < 3:
        return pts
    try:
        tri = Delaunay(pts)
    except Exception:  # noqa: BLE001 - collinear cloud: a path, no area
        order = np.argsort(pts[:, 0] + 1e-3 * pts[:, 1])
        return pts[order]
    s = tri.simplices
    e = np.stack(
        [np.linalg.norm(pts[s[:, i]] - pts[s[:, (i + 1) % 3]], axis=1) for i in range(3)], axis=1
    )
    keep = s[np.max(e, axis=1) <= max_edge]
    if keep.size == 0:
        keep = s
    count: dict[tuple[int, int], int] = {}
    for t in keep:
        for i in range(3):
            a, b = int(t[i]), int(t[(i + 1) % 3])
            key = (a, b) if a < b else (b, a)
            count[key] = count.get(key, 0) + 1
    edges = [k for k, c in count.items() if c == 1]
    adj: dict[int, list[int]] = {}
    for a, b in edges:
        adj.setdefault(a, []).append(b)
        adj.setdefault(b, []).append(a)
    used = set()
    loops = []
    for a, b in edges:
        if (a, b) in used:
            continue
        loop = [a]
        prev, cur = a, b
        used.add((min(a, b), max(a, b)))
        while cur != a and len(loop) <= len(edges):
            loop.append(cur)
            nxt = [v for v in adj[cur] if (min(cur, v), max(cur, v)) not in used]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            used.add((min(prev, cur), max(prev, cur)))
        loops.append(pts[loop])
    return max(loops, key=_polygon_area) if loops else pts


def reachable_region(
    mech: Mechanism,
    point: str,
    samples_per_actuator: int = 41,
    actuators: Sequence[str] | None = None,
    edge_samples: int | None = None,
    limits: Mapping[str, tuple[float, float]] | None = None,
    held: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Region reached by ``point`` while ``actuators`` run over their limits (the others held at
    the reference pose), e.g. the seed's zone of the excavator's hinge K for the Z1, Z2 ranges.

    ``actuators`` defaults to those that move the point. Limits are the scene's min / max, else
    :func:`actuator_range` (a full turn for a rotating crank); ``limits`` overrides them. The
    mechanism stays in the reference assembly mode.

    Returns a dict of plain data:

    * ``boundary`` [[x, y], ...] the closed polygon (first vertex not repeated); with two
      actuators the four extreme arcs (each actuator at its min or max while the other sweeps)
      joined in order, with ``boundary_inputs`` {actuator: [value per vertex]} (method
      'extreme_arcs'); one actuator: the path itself ('path', area 0); otherwise, or when the
      cloud does not lie inside the arcs (the map folds, or a corner of the throw box does not
      assemble), the concave hull of the cloud ('concave_hull', an estimate: edges up to 2.5
      sample spacings, so it bridges narrower notches and fills holes, its extent the
      samples'; measured against a finer grid's union of cell images: the excavator's L 0.9 %
      over, an outside reviewer's folding excavator map (--without-limits) 37 % over at 41
      samples and 3.9 % at 321, a five-bar 1.8 % under, a 2R arm's hole filled in whole);
    * ``area``, ``cloud`` (sampled points on a grid of the throws, and, where the plan is
      closed-form, between two neighbours of which one assembles and the other not, the edge:
      assembly_edges; a path gets its edges too), ``arcs`` (each with ``fixed``
      = [actuator, 'min'|'max', value], ``sweep`` and ``points``), ``limits``, ``held``;
    * ``hull_check``: ``outside`` (cloud points outside the boundary beyond ``tolerance``),
      ``max_outside``, ``convex_hull_area``, ``convex`` (the region equals its convex hull).
    """
    if point not in mech.points:
        raise ValueError(f'{mech.name!r} has no point {point!r}; points: {sorted(mech.points)}')
    # (3 at least: the extreme arcs' extent refines an extreme from a sample and its two
    # neighbours; from 2, the excavator's J came out 4 mm short)
    if isinstance(samples_per_actuator, bool) or not int(samples_per_actuator) >= 3:
        raise ValueError(f'samples_per_actuator must be at least 3 (got {samples_per_actuator!r})')
    solver = Solver(mech, outputs=[point], branch='reference')
    acts = list(actuators) if actuators is not None else _moving_actuators(mech, point, solver)
    for a in acts:
        if a not in mech.actuators:
            raise ValueError(f'{a!r} is not an actuator of {mech.name!r}')
    twice = sorted({a for a in acts if acts.count(a) > 1})
    if twice:  # (one throw on two axes: its "region" would be the diagonal's curve as an area)
        raise ValueError(f'actuator(s) named more than once: {", ".join(twice)}')
    held_vals = {
        a: (held or {}).get(a, reference_scalar(mech, a)) for a in mech.actuators if a not in acts
    }
    lims = {
        a: tuple(map(float, (limits or {}).get(a) or _actuator_limits(mech, a, 720))) for a in acts
    }
    scale = mech.length_scale
    n = int(samples_per_actuator)
    if len(acts) >= 3:
        n = max(2, min(n, int(round(30000 ** (1.0 / len(acts))))))
    ne = int(edge_samples) if edge_samples else 4 * (n - 1) + 1

    def solve(cols: Mapping[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        full = {a: np.asarray(cols[a], float) for a in acts}
        m = next(iter(full.values())).shape[0] if full else 1
        for a, v in held_vals.items():
            full[a] = np.full(m, float(v))
        r = solver.solve_batch(full)
        return r.ok, r.points[point]

    out: dict[str, Any] = {
        'point': point,
        'actuators': acts,
        'limits': {a: list(lims[a]) for a in acts},
        'held': {a: float(v) for a, v in held_vals.items()},
    }
    if not acts:
        p = reference_point(mech, point_key(mech, point))
        out.update(
            boundary=[list(map(float, p))],
            boundary_inputs={},
            area=0.0,
            extent=[[float(p[0]), float(p[0])], [float(p[1]), float(p[1])]],
            cloud=[list(map(float, p))],
            arcs=[],
            method=Boundary.POINT.value,
            hull_check={
                'outside': 0,
                'max_outside': 0.0,
                'tolerance': 0.0,
                'convex_hull_area': 0.0,
                'convex': True,
            },
        )
        return out
    # the cloud: a grid over the throws, solved in serpentine order (sequential Newton solves
    # then stay continuous), kept in natural order
    axes = [np.linspace(lims[a][0], lims[a][1], n) for a in acts]
    grid = np.array(list(itertools.product(*axes)))
    perm = np.arange(grid.shape[0])
    if len(acts) >= 2:
        rows = perm.reshape(-1, n).copy()
        rows[1::2] = rows[1::2, ::-1]
        perm = rows.reshape(-1)
    ok_s, P_s = solve({a: grid[perm, i] for i, a in enumerate(acts)})
    ok = np.zeros(grid.shape[0], bool)
    P = np.zeros((grid.shape[0], 2))
    ok[perm], P[perm] = ok_s, P_s
    # where it stops assembling between two samples (a dead centre inside the limits), the
    # edge itself: the grid's samples stop short of it by up to a step. Closed form only: its
    # batch rows are independent, where a Newton batch is one path (its bisection would jump
    # about, move the solver's mode for the solves after it and grind at caps on every miss)
    closed = solver.mode is SolveMode.CLOSED_FORM
    _, edges = assembly_edges(grid, ok, n, acts, solve) if closed else (None, np.zeros((0, 2)))
    cloud = np.concatenate([P[ok], edges])
    out['cloud'] = cloud.tolist()
    arcs = []
    if len(acts) == 1:
        a = acts[0]
        xs = np.linspace(lims[a][0], lims[a][1], ne)
        okp, pp = solve({a: xs})
        ends, at_ends = (
            assembly_edges(xs[:, None], okp, ne, acts, solve)
            if closed
            else (np.zeros((0, 1)), np.zeros((0, 2)))
        )
        throws = np.concatenate([xs[okp], ends[:, 0]])
        order = np.argsort(throws, kind='stable')
        boundary = np.concatenate([pp[okp], at_ends])[order]
        binputs = {a: throws[order].tolist()}
        method = Boundary.PATH
        area = 0.0
    elif len(acts) == 2:
        a1, a2 = acts
        (l1, h1), (l2, h2) = lims[a1], lims[a2]
        s1 = np.linspace(l1, h1, ne)
        s2 = np.linspace(l2, h2, ne)
        specs = [
            (a1, 'min', l1, a2, s2),
            (a2, 'max', h2, a1, s1),
            (a1, 'max', h1, a2, s2[::-1]),
            (a2, 'min', l2, a1, s1[::-1]),
        ]
        verts, ins1, ins2, complete = [], [], [], True
        for fixed, which, val, sweep, vals in specs:
            cols = {fixed: np.full(vals.size, val), sweep: vals}
            okp, pp = solve(cols)
            complete &= bool(okp.all())
            arcs.append(
                {
                    'fixed': [fixed, which, float(val)],
                    'sweep': sweep,
                    'inputs': vals[okp].tolist(),
                    'points': pp[okp].tolist(),
                }
            )
            # drop each arc's last vertex: it is the next arc's first (a shared corner)
            sel = np.flatnonzero(okp)
            sel = sel[sel < vals.size - 1]
            verts.append(pp[sel])
            ins1.append(cols[a1][sel])
            ins2.append(cols[a2][sel])
        boundary = np.concatenate(verts)
        binputs = {a1: np.concatenate(ins1).tolist(), a2: np.concatenate(ins2).tolist()}
        method = Boundary.EXTREME_ARCS if complete else Boundary.CONCAVE_HULL
        area = _arcs_area(boundary, [np.asarray(a['points'], float) for a in arcs])
    else:
        boundary, binputs, method, area = None, {}, Boundary.CONCAVE_HULL, 0.0
    # hull check: the cloud must lie inside the boundary
    spacing = _grid_spacing(P, ok, n, len(acts))
    tolerance = 1e-9 * scale
    hull_area = 0.0
    if len(acts) >= 2 and cloud.shape[0] >= 3:
        try:
            from scipy.spatial import ConvexHull

            hull_area = float(ConvexHull(cloud).volume)
        except Exception:  # noqa: BLE001 - degenerate cloud
            hull_area = 0.0
    outside, max_out = 0, 0.0
    if method is Boundary.EXTREME_ARCS:
        assert boundary is not None  # (two actuators: the arcs joined)
        inside = points_in_polygon(cloud, boundary)
        d = distance_to_polygon(cloud[~inside], boundary) if (~inside).any() else np.zeros(0)
        outside = int(np.sum(d > tolerance))
        max_out = float(d.max()) if d.size else 0.0
        if outside:
            method = Boundary.CONCAVE_HULL
    if method is Boundary.CONCAVE_HULL:
        pts = np.concatenate(
            [cloud] + [np.asarray(a['points'], float).reshape(-1, 2) for a in arcs]
        )
        boundary = _concave_hull(pts, 2.5 * spacing)
        binputs = {}
        area = _polygon_area(boundary)
    bpts = np.asarray(boundary, float).reshape(-1, 2)
    extent = (
        _arcs_extent(arcs, solve)
        if method is Boundary.EXTREME_ARCS
        else _path_extent(binputs[acts[0]], bpts, acts[0], solve)
        if method is Boundary.PATH and len(bpts)
        else [[float(bpts[:, i].min()), float(bpts[:, i].max())] for i in (0, 1)]
        if len(bpts)
        else []
    )
    out.update(
        boundary=bpts.tolist(),
        boundary_inputs=binputs,
        area=float(area),
        extent=extent,
        arcs=arcs,
        method=method.value,
        hull_check={
            'outside': outside,
            'max_outside': max_out,
            'tolerance': tolerance,
            'convex_hull_area': hull_area,
            'convex': bool(hull_area > 0 and area >= hull_area * (1 - 1e-3)),
        },
    )
    return out


#: halvings of a grid step that put an edge of where the mechanism assembles (between a sample
#: that assembles and its neighbour that does not) to 2^-EDGE_BISECTIONS of that step
EDGE_BISECTIONS = 48


def assembly_edges(
    grid: np.ndarray,
    ok: np.ndarray,
    n: int,
    acts: Sequence[str],
    solve: Callable[[Mapping[str, np.ndarray]], tuple[np.ndarray, np.ndarray]],
) -> tuple[np.ndarray, np.ndarray]:
    """(throws, points) where the mechanism stops assembling between neighbouring samples of a
    throw grid (``grid`` (n^k, k) in itertools.product order, ``ok`` per sample): along each
    axis, the others fixed, a sample that assembles beside one that does not brackets an edge
    (a dead centre inside the limits: the region reaches to it, its samples stop short), found
    by bisection of the throws, every bracket at once."""
    k = len(acts)
    G = grid.reshape((n,) * k + (k,))
    okg = np.asarray(ok, bool).reshape((n,) * k)
    lo_parts, hi_parts = [], []
    for ax in range(k):
        a_ok, b_ok = np.delete(okg, -1, axis=ax), np.delete(okg, 0, axis=ax)
        a_x, b_x = np.delete(G, -1, axis=ax), np.delete(G, 0, axis=ax)
        lo_parts += [a_x[a_ok & ~b_ok], b_x[~a_ok & b_ok]]
        hi_parts += [b_x[a_ok & ~b_ok], a_x[~a_ok & b_ok]]
    lo, hi = np.concatenate(lo_parts), np.concatenate(hi_parts)
    if not lo.shape[0]:
        return np.zeros((0, k)), np.zeros((0, 2))
    sample, width = lo.copy(), np.abs(hi - lo)
    for _ in range(EDGE_BISECTIONS):
        mid = 0.5 * (lo + hi)
        got, _ = solve({a: mid[:, i] for i, a in enumerate(acts)})
        lo = np.where(got[:, None], mid, lo)
        hi = np.where(got[:, None], hi, mid)
    # (an edge on the sample itself, a dead centre on the grid (taken to the tangency band's
    # hair past it), is that sample: not again)
    got, pts = solve({a: lo[:, i] for i, a in enumerate(acts)})
    keep = got & np.any(np.abs(lo - sample) > 1e-9 * width, axis=1)
    return lo[keep], pts[keep]


def _grid_spacing(P: np.ndarray, ok: np.ndarray, n: int, k: int) -> float:
    """Largest image distance between neighbouring samples of the throw grid (any axis)."""
    if k == 0 or P.shape[0] < 2:
        return 0.0
    Pg = P.reshape((n,) * k + (2,))
    okg = ok.reshape((n,) * k)
    best = 0.0
    for ax in range(k):
        d = np.linalg.norm(np.diff(Pg, axis=ax), axis=-1)
        both = np.logical_and(np.delete(okg, 0, axis=ax), np.delete(okg, -1, axis=ax))
        if both.any():
            best = max(best, float(d[both].max()))
    return best
