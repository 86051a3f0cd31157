"""The whole circuit of a Newton-placed mechanism (core.motion.trace): a Stephenson-III six-bar
driven at its output, whose inner four-bar's crank turns fully while the drive swings back and
forth. The drive's range was read as the stretch between the two turning points next to the
drawing (a walk stops at the first toggle each way, and the way back was assumed to be the
only other stretch): 3.1126..3.5462 rad with two toggles, the crank swinging 1.71 rad, where
the drive spans 3.1126..3.7526 with four toggles and the crank turns fully.

Oracles: the drive as a function of the crank by circle intersections (oracles.stephenson_drive;
the four-bar's crank turns fully and neither dyad toggles on these drawings, so the crank's
turn is the whole circuit), its turning points refined by a bounded scalar search; the rocker's
angle by the cosine rule in triangle O4-A-B, written here."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from oracles import stephenson_drive
from scenes import (
    CYLINDER_DRIVEN_TRIAD,
    CYLINDER_DRIVEN_TRIAD_POINTS,
    STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT,
)
from scipy.optimize import brentq, minimize_scalar

from linkage_ros.core.model import Scene
from linkage_ros.core.motion.quantities import input_sweep
from linkage_ros.core.motion.ranges import actuator_range

#: the turning points: the tracer's root of d(drive)/d(arclength) to ~1e-14 of a step and the
#: oracle's bounded search to 1e-12 of the crank put each drive value to rounding (the drive is
#: quadratic in either there); 1e-10 rad leaves room for the drawing's lengths, read from its
#: points, to differ by rounding between the two
AT_TURN = 1e-10
#: the rocker's extremes: each inside a stretch, the package's refined by Brent on the rate
#: between samples, the value to Newton's closure (1e-12 of the length scale) and flat there
AT_EXTREME = 1e-9


def _drawing(o6: list[float] | None = None, d: list[float] | None = None) -> dict:
    """The scene with O6 and D moved (link5 and the output redrawn: their lengths are read
    off the points), or as it is."""
    scene = copy.deepcopy(STEPHENSON_III_DRIVEN_AT_ITS_OUTPUT)
    if o6 is not None and d is not None:
        scene['points']['O6'], scene['points']['D'] = o6, d
    return scene


#: (drawing, how many turning points its drive has over the crank's turn)
DRAWINGS = {
    'four_toggles': (_drawing(), 4),
    'two_toggles': (_drawing([0.1, 0.45], [-0.15, 0.2]), 2),
}


def _least_dyad_margin(points: dict) -> float:
    """The least margin (m) of the six-bar's two dyads over the crank's turn: |A - O4| within
    (|AB - O4B|, AB + O4B) and |C - O6| within (|CD - O6D|, CD + O6D). Above 0, the crank turns
    fully with each dyad on its drawn side: the oracle's crank turn is the whole circuit."""
    P = {k: np.array(v, float) for k, v in points.items()}
    a, b, c = (np.linalg.norm(P[q] - P[p]) for p, q in (('O2', 'A'), ('A', 'B'), ('O4', 'B')))
    cd, out = np.linalg.norm(P['D'] - P['C']), np.linalg.norm(P['D'] - P['O6'])
    ab0, ac0 = P['B'] - P['A'], P['C'] - P['A']
    u, v = P['O4'] - P['A'], P['B'] - P['A']
    side = math.copysign(1.0, u[0] * v[1] - u[1] * v[0])
    least = math.inf
    for t in np.linspace(-math.pi, math.pi, 721):
        A = P['O2'] + a * np.array([math.cos(t), math.sin(t)])
        e = P['O4'] - A
        L = float(np.hypot(*e))
        least = min(least, L - abs(b - c), b + c - L)
        x = (b * b - c * c + L * L) / (2 * L)
        B = A + x * e / L + side * math.sqrt(max(b * b - x * x, 0.0)) * np.array([-e[1], e[0]]) / L
        turn = math.atan2(*(B - A)[::-1]) - math.atan2(*ab0[::-1])
        C = A + np.array(
            [
                ac0[0] * math.cos(turn) - ac0[1] * math.sin(turn),
                ac0[0] * math.sin(turn) + ac0[1] * math.cos(turn),
            ]
        )
        L = float(np.linalg.norm(C - P['O6']))
        least = min(least, L - abs(cd - out), cd + out - L)
    return least


def _turning_points(points: dict) -> list[float]:
    """The drive's values (rad, unwrapped about the drawing's) where it turns back over the
    crank's full turn: each sign change of its step on a 3600-sample grid refined by a bounded
    search."""
    drive = stephenson_drive(points)
    grid = np.linspace(-math.pi, math.pi, 3601)[:-1]
    values = [drive(t) for t in grid]
    out = []
    for i, t in enumerate(grid):
        before, here, after = values[i - 1], values[i], values[(i + 1) % len(grid)]
        if (here - before) * (after - here) < 0:
            sense = 1.0 if here < before else -1.0
            got = minimize_scalar(
                lambda c: sense * drive(c),
                bounds=(t - 0.01, t + 0.01),
                method='bounded',
                options={'xatol': 1e-12},
            )
            out.append(sense * float(got.fun))
    return out


def _rocker(points: dict):
    """The rocker O4-B's angle (rad) as a function of the crank's: the cosine rule in triangle
    O4-A-B, B on its drawn side of O4 -> A."""
    P = {k: np.array(v, float) for k, v in points.items()}
    a = float(np.linalg.norm(P['A'] - P['O2']))
    b = float(np.linalg.norm(P['B'] - P['A']))
    c = float(np.linalg.norm(P['B'] - P['O4']))
    u, v = P['A'] - P['O4'], P['B'] - P['O4']
    side = math.copysign(1.0, u[0] * v[1] - u[1] * v[0])

    def rocker(t: float) -> float:
        e = P['O2'] + a * np.array([math.cos(t), math.sin(t)]) - P['O4']
        reach = math.hypot(e[0], e[1])
        at_o4 = math.acos((c * c + reach * reach - b * b) / (2 * c * reach))
        return math.atan2(e[1], e[0]) + side * at_o4

    return rocker


def _same_angle(a: float, b: float, tol: float) -> bool:
    return abs(math.remainder(a - b, 2 * math.pi)) < tol


@pytest.mark.parametrize('key', list(DRAWINGS))
def test_the_drives_range_and_toggles_cover_the_whole_circuit(key):
    scene, count = DRAWINGS[key]
    mech = Scene.from_dict(scene).mechanism
    assert _least_dyad_margin(scene['points']) > 0.01  # (the oracle's own premise)
    turns = _turning_points(scene['points'])
    assert len(turns) == count  # (the oracle's own count: the drawing is what it says)
    got = actuator_range(mech, 'drive')
    assert not got['full_turn']
    assert got['min_source'] == 'toggle' and got['max_source'] == 'toggle'
    assert _same_angle(got['min'], min(turns), AT_TURN), (got['min'], min(turns))
    assert _same_angle(got['max'], max(turns), AT_TURN), (got['max'], max(turns))
    assert abs((got['max'] - got['min']) - (max(turns) - min(turns))) < AT_TURN
    toggles = got['toggles']
    assert len(toggles) == count, toggles
    for want in turns:
        assert any(_same_angle(t, want, AT_TURN) for t in toggles), (want, toggles)


@pytest.mark.parametrize('key', list(DRAWINGS))
def test_the_crank_turns_fully_and_the_rocker_swings_over_the_whole_circuit(key):
    scene, _ = DRAWINGS[key]
    mech = Scene.from_dict(scene).mechanism
    sweep = input_sweep(mech, ['link:crank', 'link:rocker'])
    assert not sweep.full_turn  # (the drive swings)
    assert sweep.turns_fully == ('link:crank',)
    rocker = _rocker(scene['points'])
    cranks = np.linspace(-math.pi, math.pi, 3601)
    values = np.unwrap([rocker(t) for t in cranks])
    got = sweep.outputs['link:rocker']
    for sense, want in ((1.0, got.minimum), (-1.0, got.maximum)):
        k = int(np.argmin(sense * values))
        best = minimize_scalar(
            lambda t: sense * rocker(t),
            bounds=(cranks[k] - 0.01, cranks[k] + 0.01),
            method='bounded',
            options={'xatol': 1e-12},
        )
        assert _same_angle(want, sense * float(best.fun), AT_EXTREME), (sense, want, best.fun)
    swing = float(values.max() - values.min())
    assert abs((got.maximum - got.minimum) - swing) < 1e-6  # (the grid's samples: within 1e-6)


def test_limits_that_split_the_circuit_keep_the_drawings_part():
    """Drive limits 3.2 .. 3.6 rad cut the four-toggle circuit into two parts joined only at
    its outer toggles (3.1126 and 3.7526, both outside them): the part the drawing is on is
    what the mechanism reaches, where the crank was read swinging 255 deg over both (an
    adversary). Oracle: the crank interval about the drawing's crank where the drive (by
    circle intersections) stays within the limits, its ends where the drive meets a limit
    (brentq), and the rocker's extremes over it (cosine rule, a bounded search)."""
    scene = _drawing()
    scene['actuators']['drive'].update(min=3.2, max=3.6)
    mech = Scene.from_dict(scene).mechanism
    sweep = input_sweep(mech, ['link:crank', 'link:rocker'])
    drive = stephenson_drive(scene['points'])
    P = scene['points']
    t0 = math.atan2(P['A'][1] - P['O2'][1], P['A'][0] - P['O2'][0])

    def inside(t: float) -> float:  # > 0 within the limits (the drive taken mod 2 pi)
        d = math.remainder(drive(t) - 3.4, 2 * math.pi)
        return 0.2 - abs(d)

    ends = []
    for step in (0.001, -0.001):  # from the drawing's crank each way to where a limit stops it
        t = t0
        while inside(t + step) > 0:
            t += step
        ends.append(brentq(inside, t, t + step, xtol=1e-14))
    lo, hi = min(ends), max(ends)
    crank = sweep.outputs['link:crank']
    assert 'link:crank' not in sweep.turns_fully
    assert _same_angle(crank.minimum, lo, 1e-9) and _same_angle(crank.maximum, hi, 1e-9)
    raw = _rocker(P)
    ref = raw(t0)

    def rocker(t: float) -> float:  # (on the drawing's turn: the cosine rule's atan2 wraps)
        return ref + math.remainder(raw(t) - ref, 2 * math.pi)

    ts = np.linspace(lo, hi, 2001)
    values = [rocker(t) for t in ts]
    got = sweep.outputs['link:rocker']
    for sense, want in ((1.0, got.minimum), (-1.0, got.maximum)):
        k = int(np.argmin([sense * v for v in values]))
        best = minimize_scalar(
            lambda t: sense * rocker(t),
            bounds=(max(lo, ts[k] - 0.01), min(hi, ts[k] + 0.01)),
            method='bounded',
            options={'xatol': 1e-12},
        )
        # (at an end of the interval, a limit: the value there, which a bounded search only
        # approaches)
        extreme = min(float(best.fun), sense * rocker(lo), sense * rocker(hi))
        assert _same_angle(want, sense * extreme, AT_EXTREME), (sense, want, extreme)


def test_the_curves_draw_every_stretch_of_the_circuit(tmp_path):
    """`range --curves` swept each loop-Jacobian mode from the drawing: one stretch per mode,
    half of this circuit's four. Every stretch is drawn now: the drive's samples reach both
    ends of its range and the crank's go all the way round."""
    from linkage_ros.plots import plot_output_vs_input

    scene, _ = DRAWINGS['four_toggles']
    mech = Scene.from_dict(scene).mechanism
    turns = _turning_points(scene['points'])
    d = plot_output_vs_input(mech, 'drive', 'crank', tmp_path / 'c.png', samples=181)
    assert len(d['branches']) == 4, sorted(d['branches'])
    drives = [v for br in d['branches'].values() for v in br['input']]
    assert _same_angle(min(drives), min(turns), AT_TURN)
    assert _same_angle(max(drives), max(turns), AT_TURN)
    cranks = np.sort(
        np.mod([v for br in d['branches'].values() for v in br['output']], 2 * math.pi)
    )
    assert np.diff(np.append(cranks, cranks[0] + 2 * math.pi)).max() < 0.2


def test_a_circuit_where_the_crank_rocks_too():
    """O6 and D moved so that link5 and the output lie in line twice on the crank's turn (|C -
    O6| reaches CD + O6D): the crank rocks between those two dead points, and the circuit runs
    one way with D on one side of C -> O6 and back with it on the other. The drive's range was
    read as -2.5948..-2.0502 (two toggles); it is -2.5948..0.16147, with four. Oracle: the
    crank's dead points by a root of |C - O6| - (CD + O6D) (C by the four-bar's circle
    intersection), the drive on each side of C -> O6 between them, its turning points refined
    by a bounded search."""
    scene = _drawing([0.0, 0.5], [-0.0723, 0.398])
    P = {k: np.array(v, float) for k, v in scene['points'].items()}
    a, b, c = (np.linalg.norm(P[q] - P[p]) for p, q in (('O2', 'A'), ('A', 'B'), ('O4', 'B')))
    cd, out = np.linalg.norm(P['D'] - P['C']), np.linalg.norm(P['D'] - P['O6'])
    u, v = P['O4'] - P['A'], P['B'] - P['A']
    side = math.copysign(1.0, u[0] * v[1] - u[1] * v[0])
    ab0, ac0 = P['B'] - P['A'], P['C'] - P['A']

    def meet(p, r1, q, r2, sd):  # the point at r1 from p and r2 from q, sd: left of p -> q
        e = q - p
        L = float(np.hypot(*e))
        x = (r1 * r1 - r2 * r2 + L * L) / (2 * L)
        return (
            p + x * e / L + sd * math.sqrt(max(r1 * r1 - x * x, 0.0)) * np.array([-e[1], e[0]]) / L
        )

    def c_of(t):
        A = P['O2'] + a * np.array([math.cos(t), math.sin(t)])
        B = meet(A, b, P['O4'], c, side)
        turn = math.atan2(*(B - A)[::-1]) - math.atan2(*ab0[::-1])
        cs, sn = math.cos(turn), math.sin(turn)
        return A + np.array([ac0[0] * cs - ac0[1] * sn, ac0[0] * sn + ac0[1] * cs])

    def gap(t):  # below 0 where link5 and the output close
        return float(np.linalg.norm(c_of(t) - P['O6'])) - (cd + out)

    def drive(t, sd):
        D = meet(c_of(t), cd, P['O6'], out, sd)
        return math.atan2(*(D - P['O6'])[::-1])

    grid = np.linspace(-math.pi, math.pi, 7201)
    gaps = np.array([gap(t) for t in grid])
    roots = [
        brentq(gap, grid[i], grid[i + 1], xtol=1e-15)
        for i in np.flatnonzero(gaps[:-1] * gaps[1:] < 0)
    ]
    assert len(roots) == 2  # the crank's two dead points; it closes between them (gap < 0)
    lo_t = max(r for r in roots if gap(r - 1e-3) > 0)  # (the stretch the drawing's crank is on)
    hi_t = [r for r in roots if r != lo_t][0] + 2 * math.pi * (lo_t > roots[0])
    assert lo_t < 1.0471975511965976 < hi_t  # the drawn crank
    turns = []
    inner = np.linspace(lo_t, hi_t, 8001)[1:-1]
    step = inner[1] - inner[0]
    for sd in (1, -1):
        values = np.unwrap([drive(t, sd) for t in inner])
        for i in range(1, len(inner) - 1):
            if (values[i] - values[i - 1]) * (values[i + 1] - values[i]) < 0:
                sense = 1.0 if values[i] < values[i - 1] else -1.0
                got = minimize_scalar(
                    lambda t: sense * math.remainder(drive(t, sd) - values[i], 2 * math.pi),
                    bounds=(inner[i] - step, inner[i] + step),
                    method='bounded',
                    options={'xatol': 1e-12},
                )
                turns.append(values[i] + sense * float(got.fun))
    assert len(turns) == 4, turns
    mech = Scene.from_dict(scene).mechanism
    got = actuator_range(mech, 'drive')
    assert _same_angle(got['min'], min(turns), AT_TURN), (got['min'], min(turns))
    assert _same_angle(got['max'], max(turns), AT_TURN), (got['max'], max(turns))
    assert len(got['toggles']) == 4
    for want in turns:
        assert any(_same_angle(t, want, AT_TURN) for t in got['toggles']), (want, got['toggles'])
    crank = input_sweep(mech, ['link:crank']).outputs['link:crank']
    # (at a dead point the crank moves as the square root of the drive's distance: read to 1e-9)
    assert _same_angle(crank.minimum, lo_t, 1e-9) and _same_angle(crank.maximum, hi_t, 1e-9)


def test_a_cylinder_driven_triad_without_limits_has_six_toggles():
    """A non-Grashof four-bar O2-A-B-O4 driven by a cylinder P-C on its coupler (Newton
    places it), without limits: its crank rocks between the four-bar's own dead points and the
    cylinder's length turns back six times over the circuit. main read 0.8196..1.5001 m with
    two toggles; it spans 0.39339..1.50014 m. Oracle: C carried by the four-bar (B by its
    circle intersection, on each side of A -> O4 where the four-bar closes), |P C|'s local
    extremes over the crank refined by a bounded search."""
    pts = CYLINDER_DRIVEN_TRIAD_POINTS
    scene = CYLINDER_DRIVEN_TRIAD
    P = {k: np.array(v, float) for k, v in pts.items()}
    a = float(np.linalg.norm(P['A'] - P['O2']))
    b, c = float(np.linalg.norm(P['B'] - P['A'])), float(np.linalg.norm(P['B'] - P['O4']))
    ab0, ac0 = P['B'] - P['A'], P['C'] - P['A']

    def length(t: float, sd: float) -> float:  # |P C|, nan where the four-bar does not close
        A = P['O2'] + a * np.array([math.cos(t), math.sin(t)])
        e = P['O4'] - A
        L = float(np.hypot(*e))
        x = (b * b - c * c + L * L) / (2 * L)
        if b * b - x * x < 0:
            return math.nan
        B = A + x * e / L + sd * math.sqrt(b * b - x * x) * np.array([-e[1], e[0]]) / L
        turn = math.atan2(*(B - A)[::-1]) - math.atan2(*ab0[::-1])
        cs, sn = math.cos(turn), math.sin(turn)
        C = A + np.array([ac0[0] * cs - ac0[1] * sn, ac0[0] * sn + ac0[1] * cs])
        return float(np.linalg.norm(C - P['P']))

    grid = np.linspace(-math.pi, math.pi, 20001)
    step = grid[1] - grid[0]
    turns = []
    for sd in (1.0, -1.0):
        values = np.array([length(t, sd) for t in grid])
        for i in range(1, len(grid) - 1):
            before, here, after = values[i - 1 : i + 2]
            if np.isfinite([before, here, after]).all() and (here - before) * (after - here) < 0:
                sense = 1.0 if here < before else -1.0
                got = minimize_scalar(
                    lambda t: sense * length(t, sd),
                    bounds=(grid[i] - step, grid[i] + step),
                    method='bounded',
                    options={'xatol': 1e-12},
                )
                turns.append(sense * float(got.fun))
    assert len(turns) == 6, turns
    got = actuator_range(Scene.from_dict(scene).mechanism, 'Z')
    assert got['min_source'] == 'toggle' and got['max_source'] == 'toggle'
    assert abs(got['min'] - min(turns)) < AT_TURN and abs(got['max'] - max(turns)) < AT_TURN
    assert len(got['toggles']) == 6, got['toggles']
    for want in turns:
        assert min(abs(t - want) for t in got['toggles']) < AT_TURN, (want, got['toggles'])
