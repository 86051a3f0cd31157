"""Tests of linkage_ros.core.analysis on the four-bar against brute force and closed-form oracles:
Kutzbach's DOF, the Grashof class, input and output ranges, toggle angles and the transmission
angle (any one-loop four-link chain: test_analysis_four_link_chains.py).

Rotation and range claims are checked by sweeping the position solver (does the linkage
assemble at this angle?) on fine grids and bisecting on that flag, never by re-deriving the
formulas used in the code.  Transmission angles are checked against a 50-digit cosine rule.
"""

import math

import mpmath as mp
import numpy as np
import pytest

from linkage_ros.core.analysis import (
    GrashofInfo,
    fourbar_input_intervals,
    fourbar_input_range,
    fourbar_output_intervals,
    fourbar_output_range,
    fourbar_toggle_angles,
    grashof_class,
    grashof_info,
    kutzbach_dof,
    transmission_angle,
)
from linkage_ros.core.fourbar import fourbar_forward, fourbar_inverse

TWO_PI = 2 * math.pi


# ----------------------------------------------------------------------------- Kutzbach


@pytest.mark.parametrize(
    'name,n,j,dof',
    [
        ('four-bar', 4, 4, 1),
        ('Peaucellier inversor', 8, 10, 1),
        ('Hart inversor', 6, 7, 1),
        ('plagiograph', 5, 5, 2),
        ('loader', 9, 11, 2),
        ('excavator', 12, 15, 3),
        ('slider-crank', 4, 4, 1),
        ('five-bar', 5, 5, 2),
        ('structure (triangle)', 3, 3, 0),
    ],
)
def test_kutzbach_lecture_numbers(name, n, j, dof):
    assert kutzbach_dof(n, j) == dof


def test_kutzbach_higher_pairs():
    # cam-follower: cam, follower, ground; 2 lower pairs and 1 higher pair -> 1
    assert kutzbach_dof(3, 2, 1) == 1


# ----------------------------------------------------------------------------- brute force oracles


def _input_turns_fully(lengths, n=7201):
    t2 = np.linspace(0.0, TWO_PI, n)
    return bool(fourbar_forward(*lengths, t2).ok.all())


def _output_turns_fully(lengths, n=7201):
    t4 = np.linspace(0.0, TWO_PI, n)
    return bool(fourbar_inverse(*lengths, t4).ok.all())


def _ok_boundaries(ok_of, n=20000):
    """Angles in [0, 2 pi) where ok_of(angle) switches, by a sweep plus bisection to ~1e-14."""
    grid = np.linspace(-np.pi, np.pi, n, endpoint=False)
    ok = np.asarray(ok_of(grid), bool)
    edges = []
    for i in np.nonzero(ok != np.roll(ok, -1))[0]:
        a, b = grid[i], grid[i] + (grid[1] - grid[0])
        ok_a = bool(ok[i])
        for _ in range(60):
            m = 0.5 * (a + b)
            if bool(ok_of(m)) == ok_a:
                a = m
            else:
                b = m
        edges.append((0.5 * (a + b)) % TWO_PI)
    return sorted(edges)


def _circ_dist(a, b):
    d = abs(a - b) % TWO_PI
    return min(d, TWO_PI - d)


def _endpoints_mod_2pi(intervals):
    return sorted(v % TWO_PI for iv in intervals for v in iv)


# ----------------------------------------------------------------------------- Grashof

# (lengths l1 ground, l2 input, l3 coupler, l4 output), class, input turns, output turns
GRASHOF_CASES = [
    ((4.0, 1.5, 4.5, 3.0), 'crank-rocker', True, False),  # shortest = input
    ((4.0, 3.0, 4.5, 1.5), 'crank-rocker', False, True),  # shortest = output
    ((7.0, 2.0, 8.0, 5.0), 'crank-rocker', True, False),
    ((1.5, 4.0, 4.5, 3.0), 'double-crank', True, True),  # shortest = ground
    ((2.0, 7.0, 6.0, 5.0), 'double-crank', True, True),
    ((4.0, 3.0, 1.5, 4.5), 'grashof-double-rocker', False, False),  # shortest = coupler
    ((4.0, 2.0, 5.0, 3.0), 'change-point', True, False),  # 2 + 5 == 4 + 3
    ((2.0, 1.0, 2.0, 1.0), 'change-point', True, True),  # parallelogram
    ((2.0, 2.0, 1.0, 1.0), 'change-point', False, True),  # kite
    ((3.0, 1.0, 2.0, 2.0), 'change-point', True, False),  # 1 + 3 == 2 + 2
    ((4.0, 3.0, 5.0, 2.5), 'triple-rocker', False, False),
    ((5.0, 4.0, 2.5, 3.0), 'triple-rocker', False, False),
    ((3.0, 2.0, 2.5, 4.0), 'triple-rocker', False, False),
]


@pytest.mark.parametrize('lengths,klass,inp,out', GRASHOF_CASES)
def test_grashof_examples_and_rotation_by_brute_force(lengths, klass, inp, out):
    info = grashof_info(*lengths)
    assert isinstance(info, GrashofInfo)
    assert info.klass == klass == grashof_class(*lengths)
    # the rotation claims of the table are confirmed by sweeping the solver ...
    assert _input_turns_fully(lengths) == inp
    assert _output_turns_fully(lengths) == out
    # ... and reported by grashof_info
    assert info.input_fully_rotates == inp and info.output_fully_rotates == out
    s, p, q, lng = sorted(lengths)
    assert (info.s, info.p, info.q, info.l) == (s, p, q, lng)
    assert info.assemblable


def test_grashof_class_agrees_with_brute_force_on_random_linkages():
    rng = np.random.default_rng(5)
    seen = set()
    tested = 0
    while tested < 150:
        lengths = tuple(rng.uniform(0.5, 5.0, 4))
        s, p, q, lng = sorted(lengths)
        # stay clear of the change-point, where unreachable gaps get arbitrarily thin
        if abs((s + lng) - (p + q)) < 0.05 * sum(lengths) or lng > s + p + q:
            continue
        info = grashof_info(*lengths)
        inp, out = _input_turns_fully(lengths, 3601), _output_turns_fully(lengths, 3601)
        assert (info.input_fully_rotates, info.output_fully_rotates) == (inp, out)
        # the Grashof rule and the rotation behaviour tell the same story
        expected = {
            (True, True): {'double-crank'},
            (True, False): {'crank-rocker'},
            (False, True): {'crank-rocker'},
            (False, False): {'grashof-double-rocker', 'triple-rocker'},
        }[(inp, out)]
        assert info.klass in expected
        if info.klass in ('grashof-double-rocker', 'triple-rocker'):
            # Grashof double-rocker: the coupler turns fully relative to the others, i.e. the
            # input moves on two separate circuits; a triple-rocker has a single circuit
            n_int = len(fourbar_input_intervals(*lengths))
            assert n_int == (2 if info.klass == 'grashof-double-rocker' else 1)
        seen.add(info.klass)
        tested += 1
    assert seen == {'crank-rocker', 'double-crank', 'grashof-double-rocker', 'triple-rocker'}


def test_grashof_change_point_tolerance_and_errors():
    # equality up to rounding: 0.1 + 0.7 vs 0.3 + 0.5 differ by one ulp in floats
    assert grashof_class(0.5, 0.1, 0.7, 0.3) == 'change-point'
    assert grashof_class(0.5, 0.1, 0.7 + 1e-9, 0.3) == 'triple-rocker'
    assert grashof_class(0.5, 0.1, 0.7 - 1e-9, 0.3) == 'crank-rocker'
    assert not grashof_info(10.0, 1.0, 1.0, 1.0).assemblable
    with pytest.raises(ValueError):
        grashof_info(1.0, 0.0, 1.0, 1.0)
    with pytest.raises(ValueError):
        grashof_info(1.0, float('nan'), 1.0, 1.0)


# ----------------------------------------------------------------------------- ranges

ROCKING_INPUT = [
    (4.0, 3.0, 5.0, 2.5),
    (5.0, 4.0, 2.5, 3.0),
    (3.0, 2.0, 2.5, 4.0),
    (4.0, 3.0, 1.5, 4.5),
    (4.0, 3.0, 4.5, 1.5),
    (3.0, 2.0, 2.0, 1.0),
]

ROCKING_OUTPUT = [
    (4.0, 3.0, 5.0, 2.5),
    (5.0, 4.0, 2.5, 3.0),
    (3.0, 2.0, 2.5, 4.0),
    (4.0, 3.0, 1.5, 4.5),
    (4.0, 1.5, 4.5, 3.0),
    (4.0, 2.0, 5.0, 3.0),
]


@pytest.mark.parametrize('lengths', ROCKING_INPUT)
def test_input_range_endpoints_match_bisection_on_ok(lengths):
    ivs = fourbar_input_intervals(*lengths)
    brute = _ok_boundaries(lambda t: fourbar_forward(*lengths, t).ok)
    want = _endpoints_mod_2pi(ivs)
    assert len(brute) == len(want)
    for a, b in zip(brute, want):
        assert _circ_dist(a, b) <= 1e-9
    lo, hi = fourbar_input_range(*lengths)
    assert lo < hi and (lo, hi) == ivs[0]
    # the interval runs counter-clockwise from lo to hi through assemblable inputs only
    inside = np.linspace(lo, hi, 1001)[1:-1]
    assert fourbar_forward(*lengths, inside).ok.all()
    info = grashof_info(*lengths)
    if info.klass in ('triple-rocker', 'change-point'):
        # a single circuit (the change-point merges the two at a tangency): one interval,
        # symmetric about 0 or pi
        assert len(ivs) == 1
        assert abs(lo + hi) <= 1e-12 or abs(lo + hi - TWO_PI) <= 1e-12
    else:
        # two mirror-image circuits; the upper one is returned
        assert len(ivs) == 2 and 0 <= lo < hi <= math.pi
        assert ivs[1] == pytest.approx((-hi, -lo), abs=1e-15)


@pytest.mark.parametrize('lengths', ROCKING_OUTPUT)
def test_output_range_endpoints_match_bisection_on_ok(lengths):
    ivs = fourbar_output_intervals(*lengths)
    brute = _ok_boundaries(lambda t: fourbar_inverse(*lengths, t).ok)
    want = _endpoints_mod_2pi(ivs)
    assert len(brute) == len(want)
    for a, b in zip(brute, want):
        assert _circ_dist(a, b) <= 1e-9
    lo, hi = fourbar_output_range(*lengths)
    assert lo < hi
    inside = np.linspace(lo, hi, 1001)[1:-1]
    assert fourbar_inverse(*lengths, inside).ok.all()
    # the output of a crank-rocker is also swept by the forward solver: over a full crank turn
    # the open branch (+1) rocks over exactly the upper-half-plane range that is returned
    if grashof_info(*lengths).klass == 'crank-rocker':
        t4 = fourbar_forward(*lengths, np.linspace(0, TWO_PI, 20001)).theta4
        assert lo - 1e-12 <= t4.min() and t4.max() <= hi + 1e-12
        assert t4.min() == pytest.approx(lo, abs=1e-6) and t4.max() == pytest.approx(hi, abs=1e-6)


def test_kite_singularity_is_inside_the_range():
    # Kite l1 = l2, l3 = l4: at theta2 = 0 the crank pin A lands on O4 and B is undetermined
    # (the two circles coincide).  The range covers it; the solver flags that single point.
    lengths = (2.0, 2.0, 1.0, 1.0)
    lo, hi = fourbar_input_range(*lengths)
    assert (lo, hi) == pytest.approx((-math.pi / 3, math.pi / 3), abs=1e-15)
    assert not fourbar_forward(*lengths, 0.0).ok
    assert fourbar_forward(*lengths, np.array([-1e-9, 1e-9, lo, hi])).ok.all()
    assert not fourbar_forward(*lengths, np.array([lo - 1e-9, hi + 1e-9])).ok.any()


@pytest.mark.parametrize(
    'lengths', [(4.0, 1.5, 4.5, 3.0), (1.5, 4.0, 4.5, 3.0), (2.0, 1.0, 2.0, 1.0)]
)
def test_full_rotation_gives_none(lengths):
    assert fourbar_input_range(*lengths) is None
    assert fourbar_input_intervals(*lengths) is None
    assert _input_turns_fully(lengths)


def test_ranges_reject_unassemblable_linkage():
    with pytest.raises(ValueError):
        fourbar_input_range(10.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError):
        fourbar_output_range(10.0, 1.0, 1.0, 1.0)


# ----------------------------------------------------------------------------- toggles


@pytest.mark.parametrize(
    'lengths,count',
    [
        ((4.0, 3.0, 5.0, 2.5), 2),
        ((5.0, 4.0, 2.5, 3.0), 2),
        ((4.0, 3.0, 1.5, 4.5), 4),
        ((4.0, 1.5, 4.5, 3.0), 0),
        ((1.5, 4.0, 4.5, 3.0), 0),
        ((4.0, 2.0, 5.0, 3.0), 1),
    ],
)
def test_toggle_angles(lengths, count):
    l1, l2, l3, l4 = lengths
    toggles = fourbar_toggle_angles(*lengths)
    assert len(toggles) == count
    assert toggles == sorted(toggles) and all(0 <= t < TWO_PI for t in toggles)
    for t in toggles:
        # coupler and rocker collinear: |A - O4| is l3 + l4 or |l3 - l4| (coordinates, directly)
        dist = math.hypot(l2 * math.cos(t) - l1, l2 * math.sin(t))
        assert min(abs(dist - (l3 + l4)), abs(dist - abs(l3 - l4))) <= 1e-13 * max(lengths)
        sol = fourbar_forward(*lengths, t)
        assert sol.ok and sol.transmission_sin <= 1e-6
    # completeness: every sign change of (D - (l3 + l4)) (D - |l3 - l4|) on a fine grid is a toggle
    grid = np.linspace(0, TWO_PI, 100001)
    dist = np.hypot(l2 * np.cos(grid) - l1, l2 * np.sin(grid))
    g = (dist - (l3 + l4)) * (dist - abs(l3 - l4))
    for i in np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) < 0)[0]:
        assert min(_circ_dist(grid[i], t) for t in toggles) <= 1e-4
    # for a rocking input they are exactly the range endpoints
    ivs = fourbar_input_intervals(*lengths)
    if ivs is not None and count:
        assert np.allclose(toggles, _endpoints_mod_2pi(ivs), atol=1e-15)


# ----------------------------------------------------------------------------- transmission angle


def _mp_transmission(l1, l2, l3, l4, t2):
    with mp.workdps(50):
        l1, l2, l3, l4, t2 = (mp.mpf(float(v)) for v in (l1, l2, l3, l4, t2))
        d2 = l1**2 + l2**2 - 2 * l1 * l2 * mp.cos(t2)
        c = (l3**2 + l4**2 - d2) / (2 * l3 * l4)
        return float(mp.acos(min(max(c, -1), 1)))


@pytest.mark.parametrize(
    'lengths',
    [(4.0, 1.5, 4.5, 3.0), (1.5, 4.0, 4.5, 3.0), (4.0, 3.0, 5.0, 2.5), (4.0, 3.0, 1.5, 4.5)],
)
def test_transmission_angle_matches_mpmath_cosine_rule(lengths):
    t2 = np.linspace(-np.pi, np.pi, 181)
    mu = transmission_angle(*lengths, t2)
    assert mu.shape == t2.shape and np.all((mu >= 0) & (mu <= np.pi))
    sol = fourbar_forward(*lengths, t2)
    for i, t in enumerate(t2):
        want = _mp_transmission(*lengths, t)
        # accurate away from the toggles, where mu itself is ill-conditioned (sqrt-like)
        tol = 1e-12 if 1e-3 < want < np.pi - 1e-3 else 1e-7
        assert abs(mu[i] - want) <= tol
    # the same angle the forward solver sees at B, independent of branch
    ok = sol.ok
    assert np.allclose(np.sin(mu[ok]), sol.transmission_sin[ok], atol=1e-12)
    # inputs that cannot assemble get the clipped cosine rule: 0 or pi
    assert np.all((mu[~ok] == 0) | (mu[~ok] == np.pi))


def test_transmission_angle_at_toggles_and_crank_rocker_extremes():
    # At the toggles of a triple-rocker mu is exactly 0 or pi.
    lengths = (4.0, 3.0, 5.0, 2.5)
    for t in fourbar_toggle_angles(*lengths):
        mu = transmission_angle(*lengths, t)
        assert min(mu, np.pi - mu) <= 1e-7
    # Crank-rocker: extremes of mu at theta2 = 0 and pi (textbook result), checked by sweep.
    lengths = (4.0, 1.5, 4.5, 3.0)
    t2 = np.linspace(-np.pi, np.pi, 100001)
    mu = transmission_angle(*lengths, t2)
    assert mu.min() == pytest.approx(_mp_transmission(*lengths, 0.0), abs=1e-9)
    assert mu.max() == pytest.approx(_mp_transmission(*lengths, np.pi), abs=1e-9)
    assert float(transmission_angle(*lengths, 0.0)) == pytest.approx(mu.min(), abs=1e-9)
