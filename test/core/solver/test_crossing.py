"""The closed form's continuity rule near and at a change point (core.solver.crossing): a
crank-rocker a hair inside the Grashof limit passes near folding flat but cannot leave its
circuit, however coarse the commands; one exactly at the limit passes through the fold, and
continuity may take the other branch there. Oracles: the 50-digit four-bar (oracles.fourbar)
on one fixed branch, and its margin at the fold."""

from __future__ import annotations

import math

import numpy as np
import oracles as orc
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scenes import double_parallelogram, four_bar, load

from linkage_ros.core.brent import brent_minimum
from linkage_ros.core.execute import CROSSING_MARGIN
from linkage_ros.core.scalar_plan import program
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.crossing import lowest_margins

#: s + l = p + q - eps: the crank-rocker's dyad margin dips to ~0.55 sqrt(eps) at crank 0
NEAR = [1e-4, 1e-6, 1e-8, 1e-10]


def lengths(eps: float) -> tuple[float, float, float, float]:
    return (4.0, 1.5, 5.5 - eps, 3.0)  # 1.5 + 5.5 = 4 + 3: the change point at eps = 0


def oracle_branch(L, t: float, point: tuple[float, float]) -> int:
    """The oracle's branch (+1 / -1) whose B is ``point`` at crank t."""
    return min((1, -1), key=lambda b: _gap(orc.fourbar(*L, t, b)['B'], point))


def _side(r) -> float:
    """The side of B from A -> O4 (O4 = (4, 0)): the four-bar's circuit, which a crank-rocker
    never leaves."""
    (ax, ay), (bx, by) = r.points['A'], r.points['B']
    return math.copysign(1.0, (4.0 - ax) * (by - ay) - (0.0 - ay) * (bx - ax))


def _gap(p, q) -> float:
    return math.hypot(float(p[0]) - q[0], float(p[1]) - q[1])


@pytest.mark.parametrize('method', ['closed_form', 'auto'])
@pytest.mark.parametrize('steps', [241, 61, 13])
@pytest.mark.parametrize('eps', NEAR)
def test_near_a_change_point_the_circuit_is_kept(eps, steps, method):
    """Twice round in steps of 1.5 to 30 deg, continuous: every B is the oracle's on the
    first answer's branch (the closed form took the other circuit at every crank from 1e-4 in,
    240 of 480 answers, before the crossing test)."""
    L = lengths(eps)
    s = Solver(four_bar(L), method=method)
    ts = list(np.linspace(-math.pi, math.pi, steps))[:-1] * 2
    first = s.solve({'crank': ts[0]})
    assert first.success
    b = oracle_branch(L, ts[0], first.points['B'])
    side = _side(first)
    low = 1.0
    for t in ts:
        r = s.solve({'crank': t})
        assert r.success, (t, r.reason)
        assert r.branch == first.branch, (t, r.branch)
        assert _side(r) == side, t  # (the circuit, where B's two places are close to tell)
        want = orc.fourbar(*L, t, b)['B']
        assert _gap(want, r.points['B']) <= 1e-9 * 5.5 / max(r.margin, 1e-6), (t, r.margin)
        low = min(low, r.margin)
    if steps == 241:  # (the finest sweep lands beside crank 0, where the dyad folds nearest)
        assert low < 10 * math.sqrt(eps)


def test_at_the_change_point_continuity_passes_through_the_fold():
    """eps = 0: the dyad folds flat at crank 0 and both continuations are motions; continuity
    takes the one the motion's direction predicts, so the sweep crosses to the other branch
    there (the test above would fail), with B moving in steps of the crank's size."""
    L = lengths(0.0)
    s = Solver(four_bar(L), method='closed_form')
    ts = np.linspace(-0.6, 0.6, 25)
    got = [s.solve({'crank': float(t)}) for t in ts]
    assert all(r.success for r in got)
    assert got[0].branch != got[-1].branch
    step = float(ts[1] - ts[0])
    for a, r in zip(got, got[1:]):
        assert _gap(a.points['B'], r.points['B']) <= 10 * step  # (|dB/dcrank| ~ 1.5-3 m/rad)


@pytest.mark.parametrize('eps', NEAR + [0.0])
def test_lowest_margin_between_two_commands_is_the_oracles_at_the_fold(eps):
    """The margin followed between crank -0.05 and 0.3 on one branch: its lowest is the
    oracle's at crank 0 (its minimum: A nearest O4's far circle) where it is above
    CROSSING_MARGIN, and below it exactly at the change point."""
    L = lengths(eps)
    s = Solver(four_bar(L), method='closed_form', branch='+')
    c = s.compiled
    start, end = c.parse({'crank': -0.05}), c.parse({'crank': 0.3})
    low = lowest_margins(program(c.plan), c, start, end, (1,), [0])[0]
    want = float(orc.fourbar(*L, 0.0, 1)['margin'])
    if eps:  # (a margin below CROSSING_MARGIN is found only that far: the crossing's)
        assert abs(low - want) <= 1e-7, (low, want)
    assert (low <= CROSSING_MARGIN) == (eps == 0.0)


@settings(max_examples=60, deadline=None)
@given(
    eps=st.sampled_from([0.0, 1e-10, 1e-8, 1e-4]),
    a=st.floats(1e-3, 1.5),
    b=st.floats(1e-3, 1.5),
    backwards=st.booleans(),
)
def test_lowest_margin_on_any_step_over_the_fold(eps, a, b, backwards):
    """Any step from crank -a to b (or back; a + b < pi: a step goes the short way round)
    passes the fold at 0: the lowest margin found is the oracle's there, and it reads as a
    crossing exactly at the change point."""
    L = lengths(eps)
    c = Solver(four_bar(L), method='closed_form', branch='+').compiled
    ends = [c.parse({'crank': -a}), c.parse({'crank': b})]
    if backwards:
        ends.reverse()
    low = lowest_margins(program(c.plan), c, *ends, (1,), [0])[0]
    want = float(orc.fourbar(*L, 0.0, 1)['margin'])
    if eps:  # (a margin below CROSSING_MARGIN is found only that far: the crossing's)
        assert abs(low - want) <= 1e-7, (low, want)
    assert (low <= CROSSING_MARGIN) == (eps == 0.0)


@pytest.mark.parametrize(('steps', 'level'), [(361, 1e-9), (73, 5e-3)])
def test_a_coarse_step_past_a_change_point_is_taken_back_onto_the_motion(steps, level):
    """Two turns of a double parallelogram in 361 or 73 steps. At 73 a command lands 0.002 rad
    past pi having kept its signs (on the anti-parallelograms' curve: the documented 'step
    over the zone'); the next command's move back onto the parallelograms is the crossing
    the step before made, so it stands (it was put back when only the last step was
    followed, and the couplers swung 0.68 rad). Oracle: a parallelogram's coupler stays
    level; the one command past the crossing is off by its own step's miss (~0.002 rad)."""
    s = Solver(double_parallelogram(), method='closed_form')
    worst = 0.0
    for t in np.linspace(0.7, 0.7 + 4 * math.pi, steps):
        r = s.solve({'crank': float(t)})
        assert r.success, (t, r.reason)
        for link in ('coupler', 'coupler2'):
            worst = max(worst, abs(math.remainder(r.links[link], 2 * math.pi)))
    assert worst <= level


@pytest.mark.parametrize('turn', ['held', 'turned'])
@pytest.mark.parametrize('steps', [5, 20, 200])
@pytest.mark.parametrize('short', [1e-6, 1e-9, 1e-11])
def test_a_triple_rocker_driven_to_its_toggle_and_back_comes_back_mirrored(short, steps, turn):
    """config/four_bar_non_grashof.yaml: 'Driving the crank up to a toggle and back, the
    linkage comes back in the other sign of the dyad, so it reaches the mirror image'. The
    crank stops `short` of its limit acos((0.13 - 0.47^2) / 0.12) in 5 to 200 steps and turns
    back (at once, or after holding there): the way on from there reaches the toggle (the
    plan stops assembling), so continuity's move to the other sign stands (the crossing test
    alone kept the sign from 1e-11 rad short). Oracle:
    back at crank 2.0, B is the mirror in the line A -> O4 of where it started (the circles
    about A and O4 meet there too)."""
    lim = math.acos((0.13 - 0.47**2) / 0.12)
    s = Solver(load('four_bar_non_grashof'), method='closed_form')
    up = list(np.linspace(2.0, lim - short, steps))
    first = s.solve({'crank': 2.0})
    for t in up + (up[::-1] if turn == 'held' else up[-2::-1]):
        r = s.solve({'crank': float(t)})
        assert r.success, (t, r.reason)
    assert r.branch != first.branch
    a = np.array([0.2 * math.cos(2.0), 0.2 * math.sin(2.0)])
    u = np.array([0.3, 0.0]) - a
    u /= np.linalg.norm(u)
    b = np.array(first.points['B']) - a
    mirror = a + 2 * (b @ u) * u - b
    assert np.allclose(r.points['B'], mirror, rtol=0, atol=1e-9), (r.points['B'], mirror)


@settings(max_examples=80, deadline=None)
@given(
    c=st.floats(-3.0, 3.0),
    lo=st.floats(-5.0, 0.0),
    width=st.floats(1e-3, 8.0),
    depth=st.floats(0.0, 1.0),
    kink=st.booleans(),
)
def test_brent_finds_the_bottom_of_one_dip(c, lo, width, depth, kink):
    """brent_minimum against the dip's own bottom: (x - c)^2 + depth, or |x - c| + depth (a
    V, the margin at a crossing), on any bracket: the bottom to xatol where it lies inside,
    the nearer end where it does not (scipy.optimize.fminbound's contract)."""
    hi = lo + width

    def f(x):
        return (abs(x - c) if kink else (x - c) ** 2) + depth

    x, fx = brent_minimum(f, lo, hi, 1e-9)
    want = min(max(c, lo), hi)
    assert abs(x - want) <= 1e-6 + 1e-8 * abs(want)
    assert fx == f(x)


@pytest.mark.parametrize('eps', [1e-4, 1e-8, 1e-10])
@pytest.mark.parametrize('steps', [3, 12, 100])
@pytest.mark.parametrize('turn_at', [-0.02, -1e-3, 0.0, 1e-3, 0.02])
def test_a_crank_rocker_turned_back_near_a_change_point_keeps_its_circuit(eps, steps, turn_at):
    """Driven from -0.5 to ``turn_at`` (near the fold at crank 0, where the margin dips to
    ~sqrt(eps)), held there, back to -0.5, on to 0.5 and back: a turn-back in the near-toggle
    zone looks for a toggle ahead, and there is none (the margin rises again), so the circuit
    is kept. Oracle: every B is the 50-digit four-bar's on the first answer's branch."""
    L = lengths(eps)
    s = Solver(four_bar(L), method='closed_form')
    way = list(np.linspace(-0.5, turn_at, steps))
    back = list(np.linspace(turn_at, -0.5, steps))
    on = list(np.linspace(-0.5, 0.5, steps))
    first = s.solve({'crank': -0.5})
    b = oracle_branch(L, -0.5, first.points['B'])
    for t in way + [turn_at] + back + on + on[::-1]:
        r = s.solve({'crank': float(t)})
        assert r.success and r.branch == first.branch, (t, r.branch)
        want = orc.fourbar(*L, float(t), b)['B']
        assert _gap(want, r.points['B']) <= 1e-9 * 5.5 / max(r.margin, 1e-6), t


@settings(max_examples=40, deadline=None)
@given(c=st.floats(-3.0, 3.0), lo=st.floats(-5.0, 0.0), width=st.floats(1e-3, 8.0))
def test_brent_takes_fminbounds_steps(c, lo, width):
    """brent_minimum is scipy.optimize.fminbound's method, written out (the node must not
    import scipy.optimize on its command path): the same evaluations, to rounding, on a
    smooth dip."""
    from scipy.optimize import fminbound

    mine: list[float] = []
    theirs: list[float] = []

    def f(x, log):
        log.append(x)
        return math.cosh(x - c)

    brent_minimum(lambda x: f(x, mine), lo, lo + width, 1e-9)
    fminbound(f, lo, lo + width, args=(theirs,), xtol=1e-9, maxfun=100)
    assert len(mine) == len(theirs)
    assert np.allclose(mine, theirs, rtol=0, atol=1e-12)
