"""Numerical stability of Newton: over random command sequences (hypothesis) it converges or says
why, and never silently lands on another branch than the reference's.

Oracles: ``oracles`` (50-digit mpmath, float inputs taken exactly).
"""

import math

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from scenes import four_bar, slider_crank
from stability_helpers import CRANK_ROCKER, DOUBLE_ROCKER, EPS, TIGHT, TRIPLE_ROCKER, assert_finite

from linkage_ros.core.solver import Solver

AGREE = 1e-9


# =============================================================================================
# Newton: converges or says why; never silently another branch
# =============================================================================================


LINKAGES = {
    'crank_rocker': CRANK_ROCKER,
    'triple_rocker': TRIPLE_ROCKER,
    'double_rocker': DOUBLE_ROCKER,
}

_MECHS = {n: four_bar(L) for n, L in LINKAGES.items()}

_SC = slider_crank(1.0, 3.0, 0.5, 0.3)

angles = st.one_of(
    st.floats(-7.0, 7.0, allow_nan=False),
    st.sampled_from(
        [
            0.0,
            math.pi,
            -math.pi,
            0.6741305066673152,
            -0.6741305066673152,
            2.046915387706693,
            0.8410686705679302,
        ]
    ),
)


def _agree_tol(a, b):
    """Closed form vs Newton agreement (fraction of the scale) allowing for the square-root law
    near a toggle (margin ~ sqrt(distance)): AGREE away from it."""
    rho = max(EPS, a.residual or 0.0, b.residual or 0.0)
    m = min(a.margin or 0.0, b.margin or 0.0)
    return AGREE + 8 * rho / math.sqrt(m * m + rho)


@settings(
    max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(name=st.sampled_from(sorted(LINKAGES)), seq=st.lists(angles, min_size=1, max_size=6))
@example(name='crank_rocker', seq=[-0.673828125, 3.142578125])
@example(name='triple_rocker', seq=[4.0, -0.6741305066673152])
def test_newton_reference_branch_never_switches(name, seq):
    """Newton with branch 'reference' either fails with a reason, or returns the closed form's
    branch (same sign string) and the same points; it never reports success on another branch.
    Inputs are random, unreachable ones included, fed in order to one solver."""
    mech = _MECHS[name]
    nw = Solver(mech, method='newton', branch='reference')
    cf = Solver(mech, method='closed_form', branch='reference')
    for t in seq:
        r = nw.solve({'crank': t})
        c = cf.solve({'crank': t})
        assert_finite(r)
        assert_finite(c)
        if not r.success:
            assert 'Newton' in r.reason or 'assemble' in r.reason or 'reach' in r.reason, r.reason
            continue
        assert r.residual <= TIGHT
        assert c.success, (t, c.reason)
        assert r.branch == c.branch, (t, r.branch, c.branch)
        gap = (
            max(
                math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                for p in r.points
            )
            / mech.length_scale
        )
        assert gap <= _agree_tol(r, c), (t, gap)


@settings(
    max_examples=20, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(
    name=st.sampled_from(sorted(LINKAGES) + ['slider_crank']),
    seq=st.lists(angles, min_size=1, max_size=8),
)
@example(name='double_rocker', seq=[0.8410686705679302])
@example(name='triple_rocker', seq=[1.0, 0.0, 3.0, -0.6741305066673152])
def test_newton_continuous_converges_or_says_why(name, seq):
    """Newton with branch 'continuous' on random input sequences: every answer is a genuine
    configuration on the branch it names (the closed form with that explicit branch gives the
    same points), with residual <= 1e-12; every failure has a reason; the closed form agrees on
    reachability (Newton never assembles what the closed form finds unreachable)."""
    mech = _SC if name == 'slider_crank' else _MECHS[name]
    nw = Solver(mech, method='newton')
    for t in seq:
        r = nw.solve({'crank': t})
        assert_finite(r)
        if not r.success:
            assert r.reason
            continue
        assert r.residual <= TIGHT, (t, r.residual)
        c = Solver(mech, method='closed_form', branch=r.branch).solve({'crank': t})
        assert c.success, (t, c.reason)
        gap = (
            max(
                math.hypot(r.points[p][0] - c.points[p][0], r.points[p][1] - c.points[p][1])
                for p in r.points
            )
            / mech.length_scale
        )
        assert gap <= _agree_tol(r, c), (t, gap, r.margin)
