"""The multi-loop seed scenes in config/ checked against exact, solver-independent oracles.

Scenes: peaucellier.yaml, hart.yaml (seed 001 inversors), plagiograph.yaml (seed 000 copying
mechanism), front_loader.yaml and excavator.yaml (seed 003 examples 4 and 6).

Oracles (never the solver's own output):
* the design dimensions written below, against which the scene files' reference poses are
  checked first (so the files really are the seed mechanisms, assembled exactly);
* the inversion theorems of seed 001: O, P, Q collinear, OP * OQ = l^2 - s^2 (Peaucellier) or
  OA * OD / AD^2 * (AB^2 - AD^2) (Hart), and, with P on a circle through O, Q on the straight line
  perpendicular to O-OP at OT = OP * OQ / (2 r), at the height OT * tan(theta / 2) for crank angle
  theta (inscribed angle);
* the plagiograph relation of seed 000, Y = (AB / AD) e^{i alpha} X;
* rigid-body and cylinder-length constraints written out point by point, and the assembly-mode
  sign of every dyad triangle, for the hydraulic linkages;
* Kutzbach counts n, j, F as stated in the seeds, counted from the scene file itself;
* Newton on the loop-closure equations vs the closed-form dyad plan (two different algorithms).
"""

import cmath
import math

import numpy as np
import pytest
from scenes import load, raw

from linkage_ros.core.mechanism import actuator_kind
from linkage_ros.core.model import SlideActuator
from linkage_ros.core.solver import Solver

SCENES = ('peaucellier', 'hart', 'plagiograph', 'front_loader', 'excavator')

# design dimensions (m, rad) the scene files were built from
PEAUCELLIER = {'l': 0.15, 's': 0.10, 'r': 0.045}
HART = {'l': 0.15, 's': 0.07, 't': 0.4, 'r': 0.04}
PLAGIOGRAPH = {'k': 2.0, 'alpha': math.radians(-60.0), 'O2A': 0.25, 'O2C': 0.30}

# Kutzbach numbers as the seeds state them: links n, revolute pairs, prismatic pairs, DOF F
SEED_COUNTS = {
    'peaucellier': (8, 10, 0, 1),  # seed 001: n = 8, J = J1 + 2 J2 = 2 + 2*4 = 10, F = 1
    'hart': (6, 7, 0, 1),  # seed 001: n = 6, J1 = 7, F = 1
    'plagiograph': (5, 5, 0, 2),  # seed 000: n = 5, j = 3 + 2*1 = 5, F = 2
    'front_loader': (9, 9, 2, 2),  # seed 003 example 4: n = 9, 9 R + 2 P = 11, F = 2
    'excavator': (12, 12, 3, 3),  # seed 003 example 6: n = 12, 12 R + 3 P = 15, F = 3
}

#: geometric tolerance of the exact oracles, as a fraction of the mechanism's length scale
EXACT = 1e-12


def c(p):
    """A point (x, y) as a complex number."""
    return complex(p[0], p[1])


def dist(p, q):
    return abs(c(p) - c(q))


def cross(u, v):
    return u.real * v.imag - u.imag * v.real


def crank_sweep(mech, n):
    act = next(iter(mech.actuators.values()))
    return act.name, np.linspace(act.min, act.max, n)


def serpentine(*axes):
    """Every combination of the axis values, ordered so that consecutive commands differ in one
    coordinate by one grid step (a continuous path through the grid)."""
    if len(axes) == 1:
        return [(v,) for v in axes[0]]
    rest = serpentine(*axes[1:])
    out = []
    for i, v in enumerate(axes[0]):
        out += [(v,) + r for r in (rest if i % 2 == 0 else rest[::-1])]
    return out


def actuator_grid(mech, n):
    acts = list(mech.actuators.values())
    return [a.name for a in acts], serpentine(*[np.linspace(a.min, a.max, n) for a in acts])


# ---- the scene files ---------------------------------------------------------------------------


@pytest.mark.parametrize('name', SCENES)
def test_scene_loads_with_seed_kutzbach_counts_and_a_closed_form_plan(name):
    data = raw(name)
    cylinders = data.get('cylinders') or {}
    # counted from the file: a cylinder is two links (barrel at `from`, rod at `to`) and a
    # prismatic pair; a point shared by m links is m - 1 revolute pairs
    members = {k: list(v) for k, v in data['links'].items()}
    for cname, cyl in cylinders.items():
        members[f'{cname}_barrel'] = [cyl['from']]
        members[f'{cname}_rod'] = [cyl['to']]
    n = len(members)
    j_rev = sum(max(sum(p in pts for pts in members.values()) - 1, 0) for p in data['points'])
    j_pri = len(cylinders) + len(data.get('sliders') or [])
    dof = 3 * (n - 1) - 2 * (j_rev + j_pri)
    assert (n, j_rev, j_pri, dof) == SEED_COUNTS[name]

    mech = load(name)
    assert len(mech.links) == n
    assert len(mech.revolutes) == j_rev and len(mech.prismatics) == j_pri
    assert mech.dof == dof == len(mech.actuators)
    solver = Solver(mech)
    assert solver.plan.complete and solver.mode == 'closed_form'
    # one RRR dyad per loop of the mechanism: n_loops = j - n + 1
    dyads = [d for d in solver.plan.describe() if d.startswith('RRR dyad')]
    assert len(dyads) == (j_rev + j_pri) - n + 1
    for act in mech.actuators.values():
        assert act.min is not None and act.max is not None and act.min < act.max


def test_peaucellier_reference_pose_is_the_designed_inversor():
    p = raw('peaucellier')['points']
    l, s, r = PEAUCELLIER['l'], PEAUCELLIER['s'], PEAUCELLIER['r']
    for a, b in (('P', 'A'), ('A', 'Q'), ('Q', 'B'), ('B', 'P')):
        assert dist(p[a], p[b]) == pytest.approx(s, rel=1e-14)
    assert dist(p['O'], p['A']) == pytest.approx(l, rel=1e-14)
    assert dist(p['O'], p['B']) == pytest.approx(l, rel=1e-14)
    assert dist(p['OP'], p['P']) == pytest.approx(r, rel=1e-14)
    assert dist(p['O'], p['OP']) == pytest.approx(r, rel=1e-14)


def test_hart_reference_pose_is_the_designed_inversor():
    p = {k: c(v) for k, v in raw('hart')['points'].items()}
    l, s, t, r = HART['l'], HART['s'], HART['t'], HART['r']
    A, B, C, D, O, P, Q = (p[k] for k in 'ABCDOPQ')
    assert abs(B - A) == pytest.approx(l, rel=1e-14)
    assert abs(D - C) == pytest.approx(l, rel=1e-14)
    assert abs(D - A) == pytest.approx(s, rel=1e-14)
    assert abs(C - B) == pytest.approx(s, rel=1e-14)
    assert abs(O - A) == pytest.approx(t * s, rel=1e-14)
    assert abs(D - O) == pytest.approx((1 - t) * s, rel=1e-14)
    assert abs(P - A) == pytest.approx(t * l, rel=1e-14)
    assert abs(Q - D) == pytest.approx((1 - t) * l, rel=1e-14)
    # crossed (anti-parallelogram): AB and CD intersect, BD is parallel to AC and to O-P-Q
    assert cross(B - A, C - A) * cross(B - A, D - A) < 0
    for u, v in ((B - D, C - A), (P - O, B - D), (Q - O, C - A)):
        assert abs(cross(u, v)) <= 1e-14 * abs(u) * abs(v)
    assert abs(p['OP'] - O) == pytest.approx(r, rel=1e-14)
    assert abs(P - p['OP']) == pytest.approx(r, rel=1e-14)


def test_plagiograph_reference_pose_has_the_parallelogram_and_similar_triangles():
    p = {k: c(v) for k, v in raw('plagiograph')['points'].items()}
    k, alpha = PLAGIOGRAPH['k'], PLAGIOGRAPH['alpha']
    O2, A, B, C, D, E = (p[n] for n in ('O2', 'A', 'B', 'C', 'D', 'E'))
    assert abs(A - O2) == pytest.approx(PLAGIOGRAPH['O2A'], rel=1e-14)
    assert abs(C - O2) == pytest.approx(PLAGIOGRAPH['O2C'], rel=1e-14)
    assert abs((B - A) - (C - O2)) <= 1e-15  # O2ABC is a parallelogram
    # AB = (AB/AD) e^{i alpha} AD and CE = (CE/CB) e^{i alpha} CB with AB/AD = CE/CB = k
    assert abs((B - A) / (D - A) - k * cmath.exp(1j * alpha)) <= 1e-14
    assert abs((E - C) / (B - C) - k * cmath.exp(1j * alpha)) <= 1e-14


# ---- inversors: exact straight lines -----------------------------------------------------------


def _inversor_sweep(name, constant, r):
    mech = load(name)
    scale = mech.length_scale
    O, OP = c(mech.points['O']), c(mech.points['OP'])
    axis = (OP - O) / abs(OP - O)  # unit vector O -> OP (the diameter of k_p)
    ot = constant / (2 * r)  # OT = OP * OQ / (diameter of k_p)
    solver = Solver(mech)
    act, thetas = crank_sweep(mech, 241)
    for theta in thetas:
        res = solver.solve({act: float(theta)})
        assert res.success, res.reason
        P, Q = c(res.points['P']), c(res.points['Q'])
        # P on the crank circle through O, at the crank angle
        assert abs(P - (OP + r * cmath.exp(1j * theta))) <= EXACT * scale
        # O, P, Q collinear and OP * OQ = the inversion constant
        assert abs(cross(P - O, Q - O)) <= EXACT * abs(P - O) * abs(Q - O)
        assert abs(P - O) * abs(Q - O) == pytest.approx(constant, rel=EXACT, abs=0)
        # Q on the line perpendicular to O-OP at distance OT ...
        along = ((Q - O) * axis.conjugate()).real
        assert abs(along - ot) <= EXACT * scale
        # ... exactly where the inscribed angle puts it: O-P is turned from O-OP by half the
        # crank's turn from O-OP
        half = (theta - cmath.phase(axis)) / 2
        assert abs(Q - (O + axis * complex(ot, ot * math.tan(half)))) <= EXACT * scale
    return thetas


def test_peaucellier_q_traces_an_exact_straight_line():
    l, s, r = PEAUCELLIER['l'], PEAUCELLIER['s'], PEAUCELLIER['r']
    thetas = _inversor_sweep('peaucellier', l * l - s * s, r)
    # the sweep really moves Q along the line: y_Q = OT tan(theta / 2) spans +-0.1655 m
    ot = (l * l - s * s) / (2 * r)
    assert ot * math.tan(thetas[-1] / 2) > 0.16


def test_hart_q_traces_an_exact_straight_line():
    l, s, t, r = HART['l'], HART['s'], HART['t'], HART['r']
    oa, od, ad = t * s, (1 - t) * s, s
    thetas = _inversor_sweep('hart', oa * od / ad**2 * (l * l - ad * ad), r)
    assert thetas[0] < -1.9 and thetas[-1] > 1.9


# ---- plagiograph: the copy is scaled by AB/AD and turned by alpha ------------------------------


def test_plagiograph_e_copies_d_scaled_and_rotated():
    mech = load('plagiograph')
    scale = mech.length_scale
    factor = PLAGIOGRAPH['k'] * cmath.exp(1j * PLAGIOGRAPH['alpha'])
    O2 = c(mech.points['O2'])
    acts = list(mech.actuators.values())
    solver = Solver(mech, branch='reference')  # random jumps: stay in the parallelogram mode
    rng = np.random.default_rng(20240601)
    for _ in range(200):
        pair = []
        for _ in range(2):
            cmd = {a.name: float(rng.uniform(a.min, a.max)) for a in acts}
            res = solver.solve(cmd)
            assert res.success, res.reason
            pair.append((c(res.points['D']), c(res.points['E'])))
        (D1, E1), (D2, E2) = pair
        assert abs((E2 - E1) - factor * (D2 - D1)) <= EXACT * scale
        assert abs((E1 - O2) - factor * (D1 - O2)) <= EXACT * scale


def test_plagiograph_draws_a_scaled_rotated_square_by_inverse_kinematics():
    mech = load('plagiograph')
    scale = mech.length_scale
    k, alpha = PLAGIOGRAPH['k'], PLAGIOGRAPH['alpha']
    factor = k * cmath.exp(1j * alpha)
    O2 = c(mech.points['O2'])
    centre, side = c(mech.points['D']), 0.04
    corners = [centre + side * z for z in (-0.5 - 0.5j, 0.5 - 0.5j, 0.5 + 0.5j, -0.5 + 0.5j)]
    path = []
    for a, b in zip(corners, corners[1:] + corners[:1]):
        path += [a + (b - a) * f for f in np.linspace(0.0, 1.0, 10, endpoint=False)]
    path.append(corners[0])
    solver = Solver(mech, knowns=['D'])
    assert solver.plan.complete
    drawn = []
    for d in path:
        res = solver.solve({'D': (d.real, d.imag)})
        assert res.success, res.reason
        assert abs(c(res.points['D']) - d) <= EXACT * scale
        for a in mech.actuators.values():
            assert a.min - 1e-12 <= res.inputs[a.name] <= a.max + 1e-12
        drawn.append(c(res.points['E']))
    for d, e in zip(path, drawn):
        assert abs((e - O2) - factor * (d - O2)) <= EXACT * scale
    # the copy is a square of side k * 0.04 m, each edge turned by alpha from D's edge
    e_corners = drawn[0:40:10]
    for i in range(4):
        d_edge = corners[(i + 1) % 4] - corners[i]
        e_edge = e_corners[(i + 1) % 4] - e_corners[i]
        assert abs(e_edge) == pytest.approx(k * side, rel=1e-11)
        assert cmath.phase(e_edge / d_edge) == pytest.approx(alpha, abs=1e-11)
    assert abs(drawn[-1] - drawn[0]) <= EXACT * scale  # the figure closes


# ---- hydraulic linkages: rigid links, closed loops, one assembly mode --------------------------

# dyad triangles (centre 1, centre 2, solved point) whose orientation is the assembly mode
DYAD_TRIANGLES = {
    'front_loader': [('O4', 'O2', 'A'), ('B', 'O7', 'F'), ('E', 'C', 'D')],
    'excavator': [('O4', 'O2', 'A'), ('D', 'B', 'C'), ('H', 'E', 'G'), ('G', 'K', 'J')],
}


def _orientation(p1, p2, p3):
    return np.sign(
        (p2[..., 0] - p1[..., 0]) * (p3[..., 1] - p1[..., 1])
        - (p2[..., 1] - p1[..., 1]) * (p3[..., 0] - p1[..., 0])
    )


@pytest.mark.parametrize('name, n', [('front_loader', 21), ('excavator', 9)])
def test_hydraulic_linkage_links_rigid_and_loops_closed_over_the_throw_grid(name, n):
    mech = load(name)
    data = raw(name)
    scale = mech.length_scale
    ref = {k: np.asarray(v, float) for k, v in data['points'].items()}
    names, cmds = actuator_grid(mech, n)
    cols = {a: np.array([cmd[i] for cmd in cmds]) for i, a in enumerate(names)}
    res = Solver(mech).solve_batch(cols)
    assert res.ok.all(), [r for r in res.reason if r][:3]
    assert np.max(res.residual) <= EXACT
    pts = res.points
    tol = EXACT * scale
    ground = data.get('ground', 'ground')
    for p in data['links'][ground]:
        assert np.max(np.abs(pts[p] - ref[p])) <= tol
    # every link is moved rigidly: each point equals R(phi) (ref - ref0) + world0, one phi per link
    for lname, members in data['links'].items():
        p0, p1 = members[0], members[1]
        d_ref, d_now = ref[p1] - ref[p0], pts[p1] - pts[p0]
        phi = np.arctan2(d_now[:, 1], d_now[:, 0]) - math.atan2(d_ref[1], d_ref[0])
        cs, sn = np.cos(phi), np.sin(phi)
        for p in members[1:]:
            v = ref[p] - ref[p0]
            expect = pts[p0] + np.stack([cs * v[0] - sn * v[1], sn * v[0] + cs * v[1]], axis=1)
            assert np.max(np.abs(pts[p] - expect)) <= tol, (lname, p)
    # every cylinder loop closes: pin-to-pin length = the throw; barrel and rod lie on the pin line
    for cname, cyl in data['cylinders'].items():
        axis = pts[cyl['to']] - pts[cyl['from']]
        assert np.max(np.abs(np.hypot(axis[:, 0], axis[:, 1]) - cols[cname])) <= tol
        direction = np.arctan2(axis[:, 1], axis[:, 0])
        for part in ('barrel', 'rod'):
            d = res.links[f'{cname}_{part}'] - direction
            assert np.max(np.abs(np.arctan2(np.sin(d), np.cos(d)))) <= EXACT
        assert np.max(np.abs(res.joints[cname] - cols[cname])) <= tol
    # the whole box is one assembly mode: that of the reference pose
    for tri in DYAD_TRIANGLES[name]:
        want = _orientation(*(ref[p] for p in tri))
        assert want != 0 and np.all(_orientation(*(pts[p] for p in tri)) == want), tri


def test_excavator_seed_cylinder_ranges():
    acts = load('excavator').actuators
    assert (acts['Z1'].min, acts['Z1'].max) == (1.1, 1.8)  # (O2A)min, (O2A)max of seed 003
    assert (acts['Z2'].min, acts['Z2'].max) == (1.5, 2.4)  # (CB)min, (CB)max of seed 003


# ---- closed form vs Newton ---------------------------------------------------------------------

SWEEPS = {'peaucellier': 41, 'hart': 41, 'plagiograph': 7, 'front_loader': 7, 'excavator': 4}
MAX_STEP = {'angle': 0.02, 'slide': 0.02}  # rad, m per command of the walked sweep


def walked_sweep(mech, n):
    """The serpentine actuator grid, entered from the reference pose and walked in steps of at
    most MAX_STEP per actuator (a continuous path, as a user driving the mechanism would)."""
    names, cmds = actuator_grid(mech, n)
    acts = [mech.actuators[a] for a in names]
    start = []
    for a in acts:
        if isinstance(a, SlideActuator):
            cyl = raw(mech.name)['cylinders'][a.name]
            start.append(dist(mech.points[cyl['from']], mech.points[cyl['to']]))
        else:
            start.append(cmath.phase(c(mech.points[a.toward]) - c(mech.points[a.pivot])))
    path, prev = [], np.array(start)
    for cmd in cmds:
        cmd = np.array(cmd, float)
        steps = max(
            1, int(np.ceil(np.max(np.abs(cmd - prev) / [MAX_STEP[actuator_kind(a)] for a in acts])))
        )
        path += [prev + (cmd - prev) * f for f in np.arange(1, steps + 1) / steps]
        prev = cmd
    return names, path


@pytest.mark.parametrize('name', SCENES)
def test_closed_form_and_newton_agree_along_a_sweep(name):
    mech = load(name)
    scale = mech.length_scale
    names, path = walked_sweep(mech, SWEEPS[name])
    closed = Solver(mech, method='closed_form')
    newton = Solver(mech, method='newton')
    assert closed.mode == 'closed_form' and newton.mode == 'newton'
    reference_mode = ''.join('+' if sg > 0 else '-' for sg in closed.plan.reference_signs)
    for cmd in path:
        values = dict(zip(names, map(float, cmd)))
        a, b = closed.solve(values), newton.solve(values)
        assert a.success, a.reason
        assert b.success, b.reason
        assert a.branch == reference_mode  # no assembly-mode change inside the limits
        assert set(a.points) == set(b.points) == set(mech.points)
        worst = max(dist(a.points[p], b.points[p]) for p in mech.points)
        assert worst <= 1e-9 * scale, (values, worst)


# ---- regressions: branch continuity over coarse steps ----------------------------------------


def test_closed_form_continuity_keeps_the_mode_over_a_coarse_step():
    mech = load('front_loader')
    solver = Solver(mech)  # closed form, branch='continuous'
    assert solver.solve({'Z1': 1.50, 'Z2': 2.05}).success
    res = solver.solve({'Z1': 1.6667, 'Z2': 2.05})  # boom turns ~12 deg; still far from a toggle
    assert res.success and res.margin > 0.5
    # the bin's dyad triangle E-C-D keeps the orientation of the reference pose
    ref = {p: np.asarray(v, float) for p, v in raw('front_loader')['points'].items()}
    now = {p: np.asarray(v, float) for p, v in res.points.items()}
    assert _orientation(now['E'], now['C'], now['D']) == _orientation(ref['E'], ref['C'], ref['D'])


def test_newton_first_solve_far_from_the_reference_keeps_the_mode():
    mech = load('hart')
    res = Solver(mech, method='newton').solve({'crank': -1.9198621771937625})
    assert res.success
    # both modes keep O, P, Q (the flipped linkage is the mirror image in the line O-P-Q), but the
    # dyad triangle O-P-A must keep the orientation it has in the reference pose
    ref = {p: np.asarray(v, float) for p, v in raw('hart')['points'].items()}
    now = {p: np.asarray(v, float) for p, v in res.points.items()}
    assert _orientation(now['O'], now['P'], now['A']) == _orientation(ref['O'], ref['P'], ref['A'])
