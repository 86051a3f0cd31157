"""The output contract of the vectorised four-bar / slider-crank functions at the float extremes.

Contract (linkage_ros.core.fourbar): no output is ever NaN or inf; where ``ok`` is True the
angles are in (-pi, pi] and the configuration closes (small residual); inputs the fast kernels
cannot represent (lengths near 1e308 or 5e-324, signed zeros) are either solved by the scaled
general formulas or refused with ok False.  Oracles: the loop-closure equations written out by
hand on lengths normalised by the longest, and the exact power-of-two scale invariance of the
problem.
"""

import itertools
import math

import numpy as np
import pytest

from linkage_ros.core.fourbar import (
    fourbar_forward,
    fourbar_inverse,
    slider_crank_forward,
    slider_crank_inverse,
)

PI = math.pi
ULP_PI = np.spacing(PI)  # 4.4e-16
MAXF = np.finfo(float).max

# lengths across the whole float range, signed zeros and subnormals included
LENGTHS = [
    0.0,
    -0.0,
    5e-324,
    1e-310,
    2.0**-200,
    0.35,
    0.7,
    1.0,
    2.0**200,
    1e300,
    1e308,
    1.3e308,
    MAXF,
]
COORDS = LENGTHS + [-v for v in LENGTHS if v != 0]
ANGLES = [0.0, -0.0, PI, -PI, 1.0, PI / 2, -PI / 2, 3.0, -2.0]

# name, function, indices of the angle outputs
FUNCS = [
    ('fourbar_forward', fourbar_forward, (0, 1)),
    ('fourbar_inverse', fourbar_inverse, (0, 1)),
    ('slider_crank_forward', slider_crank_forward, (1,)),
    ('slider_crank_inverse', slider_crank_inverse, (0, 1)),
]


def wrapped(a):
    """|a| wrapped to [0, pi]."""
    return np.abs(np.remainder(np.asarray(a, float) + PI, 2 * PI) - PI)


def grid(name):
    """Every combination of extreme arguments (both branches) as rows of an array."""
    if name.startswith('fourbar'):
        axes = [LENGTHS] * 4 + [ANGLES]
    elif name == 'slider_crank_forward':
        axes = [LENGTHS, LENGTHS, COORDS, ANGLES]
    else:
        axes = [LENGTHS, LENGTHS, COORDS, COORDS]
    return np.array(list(itertools.product(*axes, (1.0, -1.0)))).T


def hand_closure(name, args, sol):
    """Loop misclosure / longest length, written out directly with every length divided by the
    longest first (so that lengths near 1e308 do not overflow the check itself)."""
    if name.startswith('fourbar'):
        l1, l2, l3, l4, t = args[:5]
        m = np.maximum(np.maximum(np.abs(l1), np.abs(l2)), np.maximum(np.abs(l3), np.abs(l4)))
        m = np.where(m > 0, m, 1.0)
        l1, l2, l3, l4 = l1 / m, l2 / m, l3 / m, l4 / m
        if name == 'fourbar_forward':
            t2, t3, t4 = t, sol.theta3, sol.theta4
        else:
            t2, t3, t4 = sol.theta2, sol.theta3, t
        ex = l2 * np.cos(t2) + l3 * np.cos(t3) - l4 * np.cos(t4) - l1
        ey = l2 * np.sin(t2) + l3 * np.sin(t3) - l4 * np.sin(t4)
        return np.hypot(ex, ey)
    r, l, e = args[:3]
    if name == 'slider_crank_forward':
        t2, t3, x = args[3], sol.theta3, sol.x
    else:
        t2, t3, x = sol.theta2, sol.theta3, args[3]
    m = np.maximum(np.maximum(np.abs(r), np.abs(l)), np.maximum(np.abs(e), np.abs(x)))
    m = np.where(m > 0, m, 1.0)
    ex = (r / m) * np.cos(t2) + (l / m) * np.cos(t3) - x / m
    ey = (r / m) * np.sin(t2) + (l / m) * np.sin(t3) - e / m
    return np.hypot(ex, ey)


def assert_contract(name, angle_idx, args, sol, closes=True):
    ok = np.asarray(sol.ok)
    for k, out in enumerate(sol):
        if np.asarray(out).dtype == bool:
            continue
        bad = np.flatnonzero(~np.isfinite(out))
        assert bad.size == 0, (name, k, [a[bad[0]] for a in args], [o[bad[0]] for o in sol])
    for k in angle_idx:
        a = np.asarray(sol[k])
        bad = np.flatnonzero(ok & ~((a > -PI) & (a <= PI)))
        assert bad.size == 0, (name, k, [v[bad[0]] for v in args], [o[bad[0]] for o in sol])
    if closes:
        bad = np.flatnonzero(ok & ~(np.asarray(sol.residual) <= 1e-11))
        assert bad.size == 0, (name, [v[bad[0]] for v in args], [o[bad[0]] for o in sol])
        mis = hand_closure(name, args, sol)
        # a subnormal x is the exact one rounded to the subnormal grid (spacing 2**-1074)
        slack = 0.0
        if name == 'slider_crank_forward':
            m = np.maximum(
                np.maximum(np.abs(args[0]), np.abs(args[1])),
                np.maximum(np.abs(args[2]), np.abs(sol.x)),
            )
            slack = 2.0**-1074 / np.where(m > 0, m, 1.0)
        bad = np.flatnonzero(ok & ~(mis <= 1e-11 + slack))
        assert bad.size == 0, (
            name,
            [v[bad[0]] for v in args],
            [o[bad[0]] for o in sol],
            mis[bad[0]],
        )


# ----------------------------------------------------------------------------- reported cases


def test_reported_slider_inverse_with_overflowing_centre_distance():
    # |B| = hypot(1.3e308, 1.3e308) overflows; the circles are 1.8e308 apart, radii 0.35, 0.2
    sol = slider_crank_inverse(0.35, 0.2, 1.3e308, 1.3e308)
    assert all(np.isfinite(v) for v in sol)
    assert not sol.ok


def test_reported_slider_forward_whose_x_overflows():
    # x = r + l = 2e308 is not a float: refused, with the finite placeholder x = A_x
    sol = slider_crank_forward(1e308, 1e308, 0.0, 0.0)
    assert all(np.isfinite(v) for v in sol)
    assert not sol.ok
    assert sol.x == 1e308 and sol.theta3 == 0.0
    # the other branch, x = A_x - l = 0, is representable and solved
    sol = slider_crank_forward(1e308, 1e308, 0.0, 0.0, -1)
    assert sol.ok and sol.x == 0.0 and sol.theta3 == PI and sol.residual <= 1e-15


def test_reported_slider_forward_signed_zero_gives_minus_pi():
    sol = slider_crank_forward(0.05, 0.18, -0.0, 0.0, -1)
    assert sol.ok and sol.theta3 == PI
    assert abs(sol.x - (-0.13)) <= 1e-16


# ----------------------------------------------------------------------------- -pi

# inputs that gave exactly -pi (signed zeros, sin(-pi) = -1.2e-16): args -> output name
MINUS_PI_CASES = {
    fourbar_forward: [
        ((1.0, 0.35, 0.35, 1.0, -0.0, -1), 'theta3'),
        ((1.0, 0.35, 0.35, 1.0, -0.0, -1), 'theta4'),
        ((1.0, 1.0, 1.0, 1.0, -PI, 1), 'theta4'),
    ],
    fourbar_inverse: [
        ((1.0, 1.0, 1.0, 1.0, -PI, 1), 'theta2'),
        ((1.0, 1.0, 1.0, 1.0, -PI, -1), 'theta3'),
        ((1.0, 1.0, 0.35, 0.35, PI, 1), 'theta3'),
    ],
    slider_crank_forward: [
        ((1.0, 1.0, 0.0, PI, -1), 'theta3'),
        ((1.0, 1.0, -0.0, 0.0, -1), 'theta3'),
    ],
    slider_crank_inverse: [
        ((1.0, 1.0, 1.0, -1.0, -1), 'theta3'),
        ((1.0, 1.0, -1.0, -1.0, -1), 'theta2'),
    ],
}


@pytest.mark.parametrize('fn', list(MINUS_PI_CASES))
def test_direction_pi_is_plus_pi(fn):
    nl = 4 if fn in (fourbar_forward, fourbar_inverse) else 3
    for args, out in MINUS_PI_CASES[fn]:
        for scale in (1.0, 2.0**300, 2.0**-1060):  # the fast and the general forms
            a = [v * scale for v in args[:nl]] + list(args[nl:])
            if fn is slider_crank_inverse:
                a[3] *= scale
            one = fn(*a)
            assert one.ok and getattr(one, out) == PI, (args, scale, out, one)
            # the same element inside a batch, next to elements that go to the general form
            # (NaN, huge) and would hide a block-level check that is not NaN-proof
            batch = [np.array([v, np.nan, v, 1e308, v]) for v in a]
            sol = fn(*batch)
            assert np.all(sol.ok[[0, 2, 4]]), (args, scale)
            assert np.all(getattr(sol, out)[[0, 2, 4]] == PI), (args, scale, out, sol)


# ----------------------------------------------------------------------------- the contract


@pytest.mark.parametrize('name, fn, angle_idx', FUNCS)
def test_contract_on_a_grid_of_extreme_inputs(name, fn, angle_idx):
    args = grid(name)
    with np.errstate(all='raise'):
        sol = fn(*args)
    assert_contract(name, angle_idx, args, sol)
    assert 0.01 < sol.ok.mean() < 0.5  # a real mix of solvable and unsolvable
    # each element as in a call of its own
    rng = np.random.default_rng(5)
    for i in rng.choice(args.shape[1], 300, replace=False):
        one = fn(*args[:, i])
        for k in range(len(one)):
            assert float(one[k]) == float(sol[k][i]), (name, args[:, i], one, k)


@pytest.mark.parametrize('name, fn, angle_idx', FUNCS)
def test_outputs_stay_finite_with_a_coarse_tangency_clamp(name, fn, angle_idx):
    # a clamp of order 1 accepts degenerate triangles (a link 1e-308 times the others)
    args = grid(name)
    for tol in (1.0, np.inf):
        sol = fn(*args, tangency_tol=tol)
        assert_contract(name, angle_idx, args, sol, closes=False)


# ----------------------------------------------------------------------------- scale invariance

# lengths with short mantissas, so that every scaled length below is exact (subnormals included)
FB_LINKAGES = [(4.0, 1.5, 4.5, 3.0), (4.0, 3.0, 5.0, 2.5), (1.0, 0.25, 1.125, 0.75)]
SC_LINKAGES = [(1.0, 3.0, 0.5), (2.0, 1.0, -0.25), (1.0, 1.0, 0.0)]
# exponents k of the scale 2**k: subnormal, the general form's range, the fast range, near max
EXPONENTS = [-1066, -1040, -1000, -700, -201, -120, 0, 120, 201, 700, 1000, 1018, 1021]
REF = 300  # the general form, far from both ends of the float range


def _scaled_call(name, fn, base, u, k):
    s = 2.0**k
    if name == 'slider_crank_inverse':
        return fn(*(v * s for v in base), u * s, np.array([[1.0], [-1.0]]))
    return fn(*(v * s for v in base), u, np.array([[1.0], [-1.0]]))


@pytest.mark.parametrize('name, fn, angle_idx', FUNCS)
def test_scaling_all_lengths_by_a_power_of_two(name, fn, angle_idx):
    if name == 'slider_crank_inverse':
        u = np.arange(-72, 73) / 16.0  # slider positions, exact at every scale
    else:
        u = np.linspace(-PI, PI, 91)
    linkages = FB_LINKAGES if name.startswith('fourbar') else SC_LINKAGES
    for k, base in itertools.product(EXPONENTS, linkages):
        ref = _scaled_call(name, fn, base, u, REF)
        sol = _scaled_call(name, fn, base, u, k)
        args = [
            np.broadcast_to(v, sol.ok.shape).ravel()
            for v in (
                [b * 2.0**k for b in base]
                + [u * 2.0**k if name == 'slider_crank_inverse' else u, np.array([[1.0], [-1.0]])]
            )
        ]
        assert_contract(name, angle_idx, args, type(sol)(*(np.ravel(o) for o in sol)))
        assert ref.ok.mean() > 0.1
        if name == 'slider_crank_forward':
            # x beyond the float range cannot be returned: refused there, and only there
            fits = np.abs(np.ldexp(ref.x, k - REF)) < MAXF * (1 - 1e-15)
            assert np.array_equal(sol.ok, ref.ok & fits), (k, base)
            both = sol.ok
            # x to a few ulps of the longest length, or rounded to the subnormal grid
            tol = np.maximum(
                4 * np.spacing(2.0**REF * max(map(abs, base))), np.ldexp(1.0, -1074 + REF - k)
            )
            assert np.all(np.abs(np.ldexp(sol.x[both], REF - k) - ref.x[both]) <= tol)
        else:
            assert np.array_equal(sol.ok, ref.ok), (k, base)
            both = sol.ok
        for i in angle_idx:
            # a few ulps (pi's ulp) between scales: the problem is exactly scale-invariant
            assert np.max(wrapped(sol[i] - ref[i])[both], initial=0.0) <= 4 * ULP_PI, (k, base, i)
