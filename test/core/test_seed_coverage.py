"""Claims of seed 001 (/work/shared/seeds, exact straight-line mechanisms) that no other test
file checks: the Scott-Russell mechanism, the principle of inversion, and the Peaucellier and
Hart inversors (as cells of two DOF and as the shipped mechanisms' variants). Seeds 000 and 002:
test_seed_coverage_4r.py; seed 003: test_seed_coverage_loaders.py.

Every oracle is independent of the solver: the seeds' own constructions written out here
(circle intersections, the inversion of a circle), never the package's answer fed back to itself.
"""

import cmath
import math

import numpy as np
import pytest
from scenes import load, raw
from seed_coverage_helpers import EXACT, c, cross

from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

# ================================================================================================
# Seed 001: Scott-Russell, inversion, Peaucellier and Hart
# ================================================================================================


def test_scott_russell_line_is_perpendicular_to_any_slide_direction():
    """Seed 001: 'one point of the connecting rod generates an exact straight line perpendicular
    to the direction of the slider'. The shipped scene, turned so that the slide runs at 35 deg:
    C stays on the line through O2 perpendicular to the slide, |O2C| = 2 a |sin(theta2 - 35deg)|."""
    beta = math.radians(35.0)
    data = raw('scott_russell')
    rot = cmath.exp(1j * beta)
    for k, v in data['points'].items():
        z = c(v) * rot
        data['points'][k] = [z.real, z.imag]
    data['sliders'][0]['direction'] = beta
    data['actuators']['crank'].update(min=beta - 1.45, max=beta + 1.45)
    mech = Scene.from_dict(data).mechanism
    a = 0.15
    u = rot
    solver = Solver(mech, branch='reference')
    for t in np.linspace(beta - 1.45, beta + 1.45, 59):
        res = solver.solve({'crank': float(t)})
        assert res.success, res.reason
        C = c(res.points['C'])
        assert abs((C * u.conjugate()).real) <= EXACT  # no component along the slide
        assert abs(abs(C) - 2 * a * abs(math.sin(t - beta))) <= EXACT
        B = c(res.points['B'])
        assert abs((B * u.conjugate()).imag) <= EXACT  # B on the slide line
    # broken design check: with AC != AB the same construction leaves the line
    bad = raw('scott_russell')
    bad['points']['C'] = [-0.01, 0.18 + 0.0075]  # C further out along B->A (AC = 0.1625)
    bad_mech = Scene.from_dict(bad).mechanism
    xs = [Solver(bad_mech).solve({'crank': float(t)}).points['C'][0] for t in (0.3, 0.9, 1.3)]
    assert max(xs) - min(xs) > 1e-3


def _inversor_variant(stem, op):
    """The shipped inversor with its crank pivot OP moved to op (the crank P-OP keeps P's
    reference position, so its length becomes |op - P|)."""
    data = raw(stem)
    data['points']['OP'] = list(op)
    data['name'] = f'{stem}_moved_pivot'
    return Scene.from_dict(data).mechanism


INVERSION = {
    'peaucellier': 0.15**2 - 0.10**2,  # l^2 - s^2
    'hart': 0.4 * 0.6 * (0.15**2 - 0.07**2),
}  # OA OD / AD^2 (l^2 - s^2)


@pytest.mark.parametrize('stem', ['peaucellier', 'hart'])
def test_inversor_with_the_pivot_off_the_circle_through_o_draws_circles(stem):
    """Seed 001: 'if the circle k_p passes through O ... k_q becomes a straight line'; otherwise
    'P generates a circle ... Q will also generate another circle', the centres O, O_P, O_Q are
    collinear, and moving O_P to the other side gives the opposite curvature. Oracle: inversion
    in the circle of power k = OP * OQ maps the circle (c, r) to the circle of centre
    k c / (|c|^2 - r^2) and radius k r / | |c|^2 - r^2 |."""
    k = INVERSION[stem]
    mech0 = load(stem)
    P0 = c(mech0.points['P'])
    r0 = abs(P0 - c(mech0.points['OP']))
    centres = []
    for dx in (+0.006, -0.006):  # O outside, then inside, the circle k_p
        mech = _inversor_variant(stem, [r0 + dx, 0.0])
        cen = complex(r0 + dx, 0.0)
        rad = abs(P0 - cen)
        power = abs(cen) ** 2 - rad**2
        qc, qr = k * cen / power, k * rad / abs(power)
        assert abs(cross(cen, qc)) <= 1e-15  # O, O_P, O_Q collinear
        solver = Solver(mech)
        act = mech.actuators['crank']
        done, xs = 0, []
        for t in np.linspace(act.min, act.max, 41):
            res = solver.solve({'crank': float(t)})
            if not res.success:
                continue
            P, Q = c(res.points['P']), c(res.points['Q'])
            assert abs(abs(P - cen) - rad) <= EXACT
            assert abs(abs(P) * abs(Q) - k) <= 1e-12
            assert abs(abs(Q - qc) - qr) <= 1e-10 * qr
            xs.append(Q.real)
            done += 1
        assert done >= 15
        assert max(xs) - min(xs) > 1e-4  # not the straight line any more
        centres.append(qc.real)
    # opposite curvature on the two sides: the centres of Q's circles lie on opposite sides of O
    assert centres[0] > 0 > centres[1]
    # and with O_P O = O_P P (the shipped scene) the locus is the straight line x = k / (2 r0)
    qx = [Solver(mech0).solve({'crank': float(t)}).points['Q'][0] for t in (-1.0, 0.0, 1.0)]
    assert max(abs(x - k / (2 * r0)) for x in qx) <= EXACT


def _inversor_cell(stem, actuators):
    """Seed 001's inversor cell: the shipped inversor before its crank O_P P is added (O fixed,
    the only ground point), driven by two link directions ``{name: (link, pivot, toward)}``."""
    data = raw(stem)
    del data['points']['OP']
    del data['links']['crank']
    data['links']['ground'] = ['O']
    data['name'] = f'{stem}_cell'
    data['actuators'] = {
        name: {'type': 'angle', 'link': link, 'pivot': pivot, 'toward': toward}
        for name, (link, pivot, toward) in actuators.items()
    }
    data['outputs'] = ['Q', 'P']
    return Scene.from_dict(data).mechanism


def _peaucellier_cell():
    """The seven-link Peaucellier cell (the rhombus and the two long links), driven by the
    directions of OA and OB."""
    return _inversor_cell('peaucellier', {'theta_A': ('OA', 'O', 'A'), 'theta_B': ('OB', 'O', 'B')})


def _hart_cell():
    """The five-link Hart cell (the antiparallelogram with AD pivoted at O), driven by the
    directions of AD and AB."""
    return _inversor_cell('hart', {'theta_AD': ('AD', 'O', 'D'), 'theta_AB': ('AB', 'A', 'B')})


@pytest.mark.parametrize(
    'make,counts,k,reach',
    [
        (_peaucellier_cell, (7, 8, 2), INVERSION['peaucellier'], (0.1125, 0.245)),
        (_hart_cell, (5, 5, 2), INVERSION['hart'], (0.035, 0.09)),
    ],
)
def test_inversor_cell_has_two_dof_and_q_goes_anywhere_with_op_oq_constant(make, counts, k, reach):
    """Seed 001: before the crank is added the cell has n = 7, J = 2 + 2*2 = 8, F = 2
    (Peaucellier) or n = 5, J = 5, F = 2 (Hart), 'I can take this point Q anywhere in this plane
    ... restricted by the link length', and however it deforms O, P, Q stay on one line with
    OP * OQ constant. Inverse kinematics on Q alone, Q at random points of an annulus about O.
    (Peaucellier: Q is the far vertex, |OQ| > sqrt(l^2 - s^2), as in the seed's figure; nearer
    in, the reference sign of the P dyad is the folded rhombus P = Q, a different assembly.)"""
    mech = make()
    n, j, dof = counts
    assert (len(mech.links), len(mech.revolutes) + len(mech.prismatics), mech.dof) == (n, j, dof)
    assert 3 * (n - 1) - 2 * j == dof
    solver = Solver(mech, knowns=['point:Q'])
    rng = np.random.default_rng(1)
    q0 = c(mech.points['Q'])
    done = 0
    for _ in range(40):
        rad = rng.uniform(*reach)
        ang = cmath.phase(q0) + rng.uniform(-0.6, 0.6)
        Q = rad * cmath.exp(1j * ang)
        res = solver.solve({'point:Q': (Q.real, Q.imag)})
        if not res.success:
            continue
        done += 1
        P, Qs = c(res.points['P']), c(res.points['Q'])
        assert abs(Qs - Q) <= EXACT
        assert abs(cross(P, Qs)) <= 1e-12 * abs(P) * abs(Qs)  # O, P, Q collinear
        assert abs(abs(P) * abs(Qs) - k) <= 1e-12  # OP * OQ = k
    assert done >= 30


def test_hart_antiparallelogram_keeps_bd_parallel_to_ac_with_bd_ac_constant():
    """Seed 001 (Hart): 'BD will always remain parallel to AC' and x y = BD * AC = AB^2 - AD^2
    = l^2 - s^2, with OP = x OA / AD and OQ = y OD / AD (the two pairs of similar triangles)."""
    mech = load('hart')
    solver = Solver(mech)
    act = mech.actuators['crank']
    for t in np.linspace(act.min, act.max, 61):
        res = solver.solve({'crank': float(t)})
        A, B, C, D = (c(res.points[n]) for n in 'ABCD')
        P, Q, O = c(res.points['P']), c(res.points['Q']), c(res.points['O'])
        x, y = abs(B - D), abs(C - A)
        assert abs(cross(B - D, C - A)) <= 1e-12 * x * y
        assert abs(x * y - (0.15**2 - 0.07**2)) <= 1e-13
        assert abs(abs(P - O) - x * 0.4) <= EXACT  # OA / AD = 0.4
        assert abs(abs(Q - O) - y * 0.6) <= EXACT  # OD / AD = 0.6
