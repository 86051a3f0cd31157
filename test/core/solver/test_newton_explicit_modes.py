"""Newton with explicit branch signs where a dyad is on a fold (a change point, or a mode whose
dyad is degenerate): the answer is the configuration the closed form gives on those signs,
never 'converged to the other mode ... without crossing a singularity'. Oracles: the
parallelogram relations of the GRBDA four-bar (ROBOT_DESCRIPTIONS.md: the parallelogram
joint2 = -joint1, joint3 = joint1; the anti-parallelogram joint2 = joint3) and the closed form
on the same signs."""

from __future__ import annotations

import itertools
import math

import numpy as np
import oracles as orc
import pytest
from scenes import REPO, SHIPPED, four_bar, load

from linkage_ros.core.description import import_description
from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings

GRBDA = REPO / 'test' / 'fixtures' / 'robot_descriptions' / 'grbda_four_bar.urdf'


def _relation_holds(branch: str, crank: float, j: dict) -> None:
    """The GRBDA four-bar's joints against its two circuits: the parallelogram for '-' at
    positive crank and '+' at negative, the anti-parallelogram otherwise; both at crank 0
    (folded flat). To 1e-12 rad away from the fold; within 1e-6 rad of it Newton places the
    folded configuration only to about sqrt(tol) (measured 2e-6 rad at crank 0)."""
    parallelogram = (branch == '-') == (crank > 0) or crank == 0
    anti = (branch == '+') == (crank > 0) or crank == 0
    tol = 1e-12 if abs(crank) > 1e-6 else 1e-5
    if parallelogram:
        assert j['joint2'] == pytest.approx(-crank, abs=tol)
        assert j['joint3'] == pytest.approx(crank, abs=tol)
    if anti:
        assert j['joint2'] == pytest.approx(j['joint3'], abs=tol)


@pytest.mark.parametrize('branch', ['+', '-', 'reference'])
def test_a_stream_through_the_change_point_keeps_the_asked_signs(branch):
    """0.2 -> 0 -> -0.2 and on, Newton, explicit signs: each answer in the asked mode. The
    answer at crank 0 has a margin ~2e-6 (Newton places a fold only to ~sqrt(tol)); Newton
    went on from it into the other mode and refused -0.2 as 'not reachable on that branch
    without crossing a singularity'; with 'reference' (the drawing's '+', linkage solve's
    default) it refused 0.2 from the flat drawing."""
    mech = import_description(str(GRBDA)).mechanism
    e = Engine(mech, EngineSettings(solver='newton', branch=branch))
    signs = '+' if branch == 'reference' else branch
    for crank in (0.2, 0.0, -0.2, -0.0, 1e-9, -1e-9, 0.5, 2 * math.pi, -0.3):
        r = e.command({'joint1': crank})
        assert r.success, (crank, r.reason)
        assert r.branch == signs, crank
        _relation_holds(signs, math.remainder(crank, 2 * math.pi), r.joints)


@pytest.mark.parametrize('eps', [1e-6, 1e-8])
def test_newton_in_a_given_mode_turns_a_near_change_point_crank_rocker_fully(eps):
    """A crank-rocker a hair inside the Grashof limit, mode '+', Newton, two turns in steps
    of 12 deg: the '+' circuit turns fully, and every answer is the 50-digit four-bar's on it
    (to Newton's tolerance, as test_newton_fast's sweep past a toggle holds it).
    Newton's walk jumped to the other circuit after passing near the fold (its margin dips to
    ~5e-4) and refused 28 of 61 commands as 'converged to assembly mode -'."""
    L = (4.0, 1.5, 5.5 - eps, 3.0)
    e = Engine(four_bar(L), EngineSettings(solver='newton', branch='+'))
    side = None
    for t in np.linspace(-math.pi, 3 * math.pi, 61):
        r = e.command({'crank': float(t)})
        assert r.success and r.branch == '+', (t, r.reason)
        here = min((1, -1), key=lambda b: _gap(orc.fourbar(*L, float(t), b)['B'], r.points['B']))
        side = here if side is None else side
        assert here == side, t
        want = orc.fourbar(*L, float(t), side)['B']
        # (Newton's answer to its tolerance rho: near a fold a miss of rho moves B rho / margin)
        rho = max(r.residual, 2.0**-52)
        assert _gap(want, r.points['B']) / 5.5 <= 1e-9 + 8 * rho / math.sqrt(r.margin**2 + rho), t


def _gap(p, q) -> float:
    return math.hypot(float(p[0]) - q[0], float(p[1]) - q[1])


@pytest.mark.parametrize('signs', [''.join(s) for s in itertools.product('+-', repeat=3)])
def test_every_peaucellier_mode_is_the_closed_forms(signs):
    """Every sign string of Peaucellier's three dyads at crank 0.5: Newton answers what the
    closed form answers on it, labelled the same, with the drawing's link lengths (and the
    inversion where the rhombus is open). Modes +++ and ++- put A on B (Q's dyad degenerate,
    its margin 0): Newton was refused in them as 'converged to ++-' after 0 iterations."""
    mech = load('peaucellier')
    cf = Solver(mech, method='closed_form', branch=signs).solve({'crank': 0.5})
    nw = Solver(mech, method='newton', branch=signs).solve({'crank': 0.5})
    assert nw.success == cf.success, (nw.reason, cf.reason)
    if cf.success:
        assert nw.branch == cf.branch == signs
        for name, v in cf.joints.items():
            assert abs(math.remainder(nw.joints[name] - v, 2 * math.pi)) < 1e-9, name
    # the drawing's link lengths (config/peaucellier.yaml) in every mode, and in the inversor's
    # own modes (the rhombus PAQB open, A and B either side of OP) the inversion itself:
    # O, P, Q in line and OP . OQ = OA^2 - PA^2 (the lecture's straight-line motion)
    p = {k: np.array(v) for k, v in nw.points.items()}
    drawn = {k: np.array(mech.points[k], float) for k in ('O', 'P', 'A', 'Q', 'B')}
    for a, b in [('O', 'A'), ('O', 'B'), ('P', 'A'), ('A', 'Q'), ('Q', 'B'), ('B', 'P')]:
        want = np.linalg.norm(drawn[a] - drawn[b])
        assert np.linalg.norm(p[a] - p[b]) == pytest.approx(want, abs=1e-12), (a, b)
    if signs in ('+--', '-++'):
        oa, pa = np.linalg.norm(drawn['A']), np.linalg.norm(drawn['A'] - drawn['P'])
        assert abs(p['P'][0] * p['Q'][1] - p['P'][1] * p['Q'][0]) < 1e-12
        assert float(p['P'] @ p['Q']) == pytest.approx(oa * oa - pa * pa, abs=1e-12)


def test_a_solve_pruned_to_some_outputs_takes_the_reference_signs_without_a_crash():
    """Solver(mech, outputs=[...]) prunes the dyad plan to what the outputs need, whose signs
    are not the whole mechanism's: Newton in 'reference' started from the whole plan's answer
    in the pruned plan's signs and raised IndexError (a review of this change). It answers
    OB as the closed form does."""
    mech = load('peaucellier')
    nw = Solver(mech, outputs=['OB'], method='newton', branch='reference').solve({'crank': 0.5})
    cf = Solver(mech, outputs=['OB'], method='closed_form', branch='reference').solve(
        {'crank': 0.5}
    )
    assert nw.success and cf.success, (nw.reason, cf.reason)
    assert abs(math.remainder(nw.links['OB'] - cf.links['OB'], 2 * math.pi)) < 1e-9


def _pruned_cases() -> list[tuple[str, str]]:
    """(scene, point) of each shipped scene's forward solve whose closed form is complete,
    one wanted point each: every point the scene draws."""
    cases = []
    for stem in SHIPPED:
        mech = load(stem)
        if Solver(mech).compiled.full_plan.complete:
            cases += [(stem, p) for p in mech.points]
    return cases


@pytest.mark.parametrize(('stem', 'point'), _pruned_cases())
def test_newton_pruned_to_one_point_answers_in_every_asked_mode(stem, point):
    """Solver(mech, outputs=[point], branch=signs), Newton: the pruned plan's dyads (some of
    the whole mechanism's) must come out in the asked signs, the rest in the drawing's. Newton
    ignored the asked signs where the plan was pruned and answered the four-bar's '-' in '+'
    with status OK. Oracle: the closed form of the whole mechanism in the same signs (the
    pruned dyads' asked, the others' the drawing's); its point, to 1e-9 of the length scale.
    Each asked mode is solved from the reference pose (a fresh solver): a mode Newton cannot
    reach from the drawing at the drawing's own input is refused, never answered in another
    mode."""
    mech = load(stem)
    probe = Solver(mech, method='closed_form', outputs=[point])
    c = probe.compiled
    full, k = c.full_plan, c.branch_count
    # the pruned plan's dyads are the whole plan's at branch_positions (the same steps)
    assert [s.describe(c.plan) for s in c.plan.branch_steps] == [
        full.branch_steps[j].describe(full) for j in c.branch_positions
    ]
    values = probe.reference_values()
    for combo in itertools.product('+-', repeat=k) if k <= 4 else [('+',) * k, ('-',) * k]:
        signs = ''.join(combo)
        whole = list(full.reference_signs)
        for j, s in zip(c.branch_positions, combo):
            whole[j] = 1 if s == '+' else -1
        whole_text = ''.join('+' if s > 0 else '-' for s in whole)
        cf = Solver(mech, method='closed_form', branch=whole_text).solve(values)
        nw = Solver(mech, method='newton', outputs=[point], branch=signs).solve(values)
        if not nw.success:
            assert 'assembly mode' in nw.reason or not cf.success, (signs, nw.reason)
            continue
        assert cf.success, (signs, cf.reason)
        assert nw.branch == cf.branch, signs
        miss = math.dist(nw.points[point], cf.points[point])
        assert miss <= 1e-9 * mech.length_scale, (signs, miss)
