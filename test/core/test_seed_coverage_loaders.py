"""Claims of seed 003 (/work/shared/seeds, graphical displacement analysis) that no other test
file checks: the front-end loader (example 4, D -> D1 by the seed's construction, the bin posed by
one coordinate of its hinge and its angle) and the earth-moving machinery (example 6: the
excavator's bin to any pose, the zone of K and the bin's tilt about its lip).

Every oracle is independent of the solver: the seeds' own constructions written out here
(circle intersections, "tracing paper" rigid transfers), never the package's answer fed back to
itself.
"""

import cmath
import math

import numpy as np
import pytest
from scenes import load
from seed_coverage_helpers import EXACT, c, circ, cross, meet

from linkage_ros.core import motion
from linkage_ros.core.errors import PlanError
from linkage_ros.core.solver import Solver


def side_of(p1, p2, p3):
    """+1 if p3 is left of p1->p2, -1 if right."""
    return 1 if cross(p2 - p1, p3 - p1) > 0 else -1


def transfer(ref_a, ref_b, new_a, new_b, ref_x):
    """Tracing paper: the point of a rigid body at ref_x, when the body's points ref_a, ref_b
    have moved to new_a, new_b."""
    rot = (new_b - new_a) / (ref_b - ref_a)
    return new_a + rot / abs(rot) * (ref_x - ref_a)


# ================================================================================================
# Seed 003, example 4: the front-end loader, D -> D1 by the seed's construction
# ================================================================================================


def test_front_loader_bin_hinge_d_to_d1_matches_the_seed_construction():
    """Seed 003 example 4: when D comes to D1, C is where the circle about O4 (radius O4C) meets
    the circle about D1 (radius DC); A and B follow by tracing paper from (O4, C); E is where the
    circles about D1 (DE) and B1 (BE) meet; F by tracing paper from (B, E); the bin turns by the
    angle between CD and C1D1. With two DOF 'the orientation will be automatically fixed up':
    the package's inverse solve on D alone gives exactly this pose, and adding the bin's angle
    as a third known is refused."""
    mech = load('front_loader')
    p = {k: c(v) for k, v in mech.points.items()}
    solver = Solver(mech, knowns=['point:D'])
    for d1 in (
        p['D'] + complex(0.10, -0.20),
        p['D'] + complex(0.20, -0.10),
        p['D'] + complex(0.15, 0.30),
    ):
        C1 = meet(
            p['O4'],
            abs(p['C'] - p['O4']),
            d1,
            abs(p['D'] - p['C']),
            side_of(p['O4'], p['D'], p['C']),
        )
        A1 = transfer(p['O4'], p['C'], p['O4'], C1, p['A'])
        B1 = transfer(p['O4'], p['C'], p['O4'], C1, p['B'])
        E1 = meet(
            d1, abs(p['E'] - p['D']), B1, abs(p['E'] - p['B']), side_of(p['D'], p['B'], p['E'])
        )
        F1 = transfer(p['B'], p['E'], B1, E1, p['F'])
        res = solver.solve({'point:D': (d1.real, d1.imag)})
        assert res.success, res.reason
        for name, want in (('C', C1), ('A', A1), ('B', B1), ('E', E1), ('F', F1), ('D', d1)):
            assert abs(c(res.points[name]) - want) <= EXACT * mech.length_scale, name
        assert res.inputs['Z1'] == pytest.approx(abs(A1 - p['O2']), abs=1e-12)
        assert res.inputs['Z2'] == pytest.approx(abs(F1 - p['O7']), abs=1e-12)
        turn = cmath.phase((d1 - C1) / (p['D'] - p['C']))
        assert circ(res.links['bin'] - mech.links['bin'].angle_ref, turn) <= 1e-12
    with pytest.raises(PlanError, match='degree'):
        Solver(mech, knowns=['point:D', 'bin'])


def test_front_loader_assignment_z1_held_z2_to_three_fourths():
    """Seed 003 example 4, the assignment: "Assume the actuator Z1 is held fixed, that is the
    distance O2A is not changing and the actuator Z2 is activated to change the distance O7F
    to three-fourths of its present value, then what will be the corresponding rotation of the
    bin." The construction: the boom stays (O4, A, B, C); F1 is where the circle about O7
    (radius 3/4 O7F) meets the circle about B (radius BF), on the drawing's side; E1 by tracing
    paper from (B, F); D1 where the circles about E1 (ED) and C (CD) meet; the bin turns by the
    angle between CD and CD1. The drawn pose's Z2 and its limits leave room for it, clear of
    the tilt linkage's toggles."""
    mech = load('front_loader')
    p = {k: c(v) for k, v in mech.points.items()}
    z1, z2 = abs(p['A'] - p['O2']), abs(p['F'] - p['O7'])
    z2_new = 0.75 * z2
    F1 = meet(p['O7'], z2_new, p['B'], abs(p['F'] - p['B']), side_of(p['O7'], p['B'], p['F']))
    E1 = transfer(p['B'], p['F'], p['B'], F1, p['E'])
    D1 = meet(E1, abs(p['D'] - p['E']), p['C'], abs(p['D'] - p['C']), side_of(E1, p['C'], p['D']))
    turn = cmath.phase((D1 - p['C']) / (p['D'] - p['C']))
    for method in ('closed_form', 'newton'):
        solver = Solver(mech, method=method)
        res = solver.solve({'Z1': z1, 'Z2': z2_new})
        assert res.success, res.reason
        assert res.margin > 0.2, res.margin  # the mode's dyads clear of their toggles
        assert circ(res.links['bin'] - mech.links['bin'].angle_ref, turn) <= 1e-12
        for name, want in (('F', F1), ('E', E1), ('D', D1), ('C', p['C'])):
            assert abs(c(res.points[name]) - want) <= EXACT * mech.length_scale, name
    assert -1.2 < turn < -1.1  # the bin dumps by about 65 deg


@pytest.mark.parametrize('axis', [0, 1])
def test_front_loader_bin_by_one_coordinate_of_its_hinge_and_its_angle(axis):
    """Seed 003 example 4: the bin's two coordinates can be given as 'only the x-coordinate and
    the orientation of this bin and the y-coordinate will be automatically decided' (and so
    the y-coordinate, the x decided). The construction: with the bin's turn known, CD is a known
    vector; C is on the circle about O4 (radius O4C) with C.x = D.x - CD.x (C.y = D.y - CD.y),
    so the boom's angle is an arc cosine (arc sine) on the reference pose's side of the fold;
    D = C + CD; then A, B, E, F as in the D -> D1 construction above."""
    mech = load('front_loader')
    p = {k: c(v) for k, v in mech.points.items()}
    radius = abs(p['C'] - p['O4'])
    psi0 = cmath.phase(p['C'] - p['O4'])  # the boom's line O4 -> C in the drawing, +5 deg
    name = f'D.{"xy"[axis]}'
    # (boom turn, bin turn) from the drawing (rad): poses with both throws within their limits
    for boom_turn, bin_turn in (
        (-0.03, -0.6),
        (0.05, -0.5),
        (0.1, -0.3),
        (0.25, -0.2),
        (0.45, 0.1),
        (0.7, 0.3),
    ):
        cd = cmath.exp(1j * bin_turn) * (p['D'] - p['C'])
        d_true = p['O4'] + radius * cmath.exp(1j * (psi0 + boom_turn)) + cd
        known = (d_true - cd - p['O4']).real if axis == 0 else (d_true - cd - p['O4']).imag
        # the seed's construction from the one coordinate alone (d_true is not used below)
        psi = math.acos(known / radius) if axis == 0 else math.asin(known / radius)
        C1 = p['O4'] + radius * cmath.exp(1j * psi)
        D1 = C1 + cd
        A1 = transfer(p['O4'], p['C'], p['O4'], C1, p['A'])
        B1 = transfer(p['O4'], p['C'], p['O4'], C1, p['B'])
        E1 = meet(
            D1, abs(p['E'] - p['D']), B1, abs(p['E'] - p['B']), side_of(p['D'], p['B'], p['E'])
        )
        F1 = transfer(p['B'], p['E'], B1, E1, p['F'])
        assert abs(D1 - d_true) <= EXACT * mech.length_scale  # the construction is the pose
        bin_angle = mech.links['bin'].angle_ref + bin_turn
        value = D1.real if axis == 0 else D1.imag
        for method in ('auto', 'newton'):
            res = Solver(mech, knowns=[name, 'bin'], method=method).solve(
                {name: value, 'bin': bin_angle}
            )
            assert res.success, (boom_turn, method, res.reason)
            # the answer's error is its residual times the condition of the loop equations
            # (the fold of the x known, where the boom is horizontal, is 3 deg from the first)
            bound = max(EXACT, 10 * res.residual * res.cond) * mech.length_scale
            for point, want in (('C', C1), ('A', A1), ('B', B1), ('E', E1), ('F', F1), ('D', D1)):
                assert abs(c(res.points[point]) - want) <= bound, point
            assert res.inputs['Z1'] == pytest.approx(abs(A1 - p['O2']), abs=bound)
            assert res.inputs['Z2'] == pytest.approx(abs(F1 - p['O7']), abs=bound)
            assert circ(res.links['bin'], bin_angle) <= 1e-12
    with pytest.raises(PlanError, match='degree'):
        Solver(mech, knowns=[name, 'point:D'])
    with pytest.raises(PlanError, match='fixed by the ground'):
        Solver(mech, knowns=['O4.x', 'bin'])


# ================================================================================================
# Seed 003, example 6: the earth-moving machinery
# ================================================================================================


def excavator_k(p, z1, z2):
    """Seed 003's construction of K from the two throws (tracing paper): A from the circles about
    O4 (O4A) and O2 (Z1), the boom (O4, A, B, D) by transfer; C from the circles about D (DC) and
    B (Z2), the stick (D, C, K) by transfer. Returns (D, K)."""
    A = meet(p['O4'], abs(p['A'] - p['O4']), p['O2'], z1, side_of(p['O4'], p['O2'], p['A']))
    B = transfer(p['O4'], p['A'], p['O4'], A, p['B'])
    D = transfer(p['O4'], p['A'], p['O4'], A, p['D'])
    C = meet(D, abs(p['C'] - p['D']), B, z2, side_of(p['D'], p['B'], p['C']))
    K = transfer(p['D'], p['C'], D, C, p['K'])
    return D, K


def test_excavator_bin_to_any_pose_by_the_seed_construction():
    """Seed 003 example 6: three DOF, so the bin (hinges J, K) 'can be taken anywhere with any
    orientation'. Construction: D2 where the circles about O4 (O4D) and K2 (KD) meet; A2, B2 by
    tracing paper from (O4, D2); C2, E2, H2 from (K2, D2); G2 where the circles about J2 (JG) and
    H2 (HG) meet. The package's inverse solve on K and the bucket's angle gives that pose and the
    three throws |O2A2|, |B2C2|, |E2G2|."""
    mech = load('excavator')
    p = {k: c(v) for k, v in mech.points.items()}
    solver = Solver(mech, knowns=['point:K', 'bucket'])
    kj = abs(p['J'] - p['K'])
    for dk, dphi in (
        (complex(0.10, 0.15), -0.20),
        (complex(-0.25, 0.30), 0.10),
        (complex(0.20, -0.20), 0.05),
    ):
        K2 = p['K'] + dk
        phi = mech.links['bucket'].angle_ref + dphi
        J2 = K2 + kj * cmath.exp(1j * phi)
        D2 = meet(
            p['O4'],
            abs(p['D'] - p['O4']),
            K2,
            abs(p['D'] - p['K']),
            side_of(p['O4'], p['K'], p['D']),
        )
        A2, B2 = (transfer(p['O4'], p['D'], p['O4'], D2, p[n]) for n in 'AB')
        C2, E2, H2 = (transfer(p['K'], p['D'], K2, D2, p[n]) for n in 'CEH')
        G2 = meet(
            J2, abs(p['G'] - p['J']), H2, abs(p['G'] - p['H']), side_of(p['J'], p['H'], p['G'])
        )
        res = solver.solve({'point:K': (K2.real, K2.imag), 'bucket': phi})
        assert res.success, res.reason
        for name, want in (
            ('D', D2),
            ('A', A2),
            ('B', B2),
            ('C', C2),
            ('E', E2),
            ('H', H2),
            ('G', G2),
            ('J', J2),
            ('K', K2),
        ):
            assert abs(c(res.points[name]) - want) <= EXACT * mech.length_scale, name
        for act, want in (('Z1', abs(A2 - p['O2'])), ('Z2', abs(C2 - B2)), ('Z3', abs(G2 - E2))):
            assert res.inputs[act] == pytest.approx(want, abs=1e-12), act


def test_excavator_zone_of_k_edges_are_the_seed_arcs():
    """Seed 003 example 6, second part: with an actuator at an extreme, 'link 4 and link 7 get
    rigidly connected': with Z2 held, K moves on a circle about O4; with Z1 held, D stays at D'
    (or D'') and K moves on a circle about it of radius DK. The four edges of the package's
    region of K for the seed's throw ranges (O2A 1.1..1.8 m, CB 1.5..2.4 m) lie on those circles."""
    mech = load('excavator')
    p = {k: c(v) for k, v in mech.points.items()}
    reg = motion.reachable_region(mech, 'K', actuators=['Z1', 'Z2'], samples_per_actuator=9)
    assert len(reg['arcs']) == 4
    dk = abs(p['K'] - p['D'])
    for arc in reg['arcs']:
        fixed, _, val = arc['fixed']
        pts = [c(q) for q in arc['points']]
        assert len(pts) >= 20
        if fixed == 'Z2':
            _, K_any = excavator_k(p, 1.5, val)
            radius = abs(K_any - p['O4'])
            assert max(abs(abs(q - p['O4']) - radius) for q in pts) <= 1e-12
        else:
            D_fixed, _ = excavator_k(p, val, 2.0)
            assert max(abs(abs(q - D_fixed) - dk) for q in pts) <= 1e-12
        for q, z in zip(pts, arc['inputs']):
            z1, z2 = (val, z) if fixed == 'Z1' else (z, val)
            assert abs(q - excavator_k(p, z1, z2)[1]) <= 1e-12


def _fold_throw(p):
    """The Z2 at which the stick lies along the boom line (O4, D, K collinear, K between): where
    the (Z1, Z2) -> K map folds (bisection on the oracle construction)."""

    def s(z2):
        D, K = excavator_k(p, 1.5, z2)
        return cross(D - p['O4'], K - D)

    lo, hi = 1.5, 2.4
    if s(lo) * s(hi) > 0:
        return None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if s(lo) * s(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def test_excavator_zone_of_k_for_the_seed_throw_ranges_is_the_four_arc_region():
    """Seed 003: 'these four circular arcs determine the region in which the hinge K can lie when
    the maximum and minimum distance between O2 and A, and B and C are utilized'. Over the seed's
    ranges (O2A 1.1..1.8 m, CB 1.5..2.4 m, the scene's limits) the stick never reaches the boom
    line (where the (Z1, Z2) -> K map would fold), the package's region is the 'extreme_arcs'
    polygon with every sampled K inside it, and its area is that enclosed by the oracle arcs
    (shoelace on the construction, densely sampled)."""
    mech = load('excavator')
    assert (mech.actuators['Z1'].min, mech.actuators['Z1'].max) == (1.1, 1.8)
    assert (mech.actuators['Z2'].min, mech.actuators['Z2'].max) == (1.5, 2.4)
    p = {k: c(v) for k, v in mech.points.items()}
    assert _fold_throw(p) is None
    reg = motion.reachable_region(mech, 'K', actuators=['Z1', 'Z2'], samples_per_actuator=21)
    assert reg['method'] == 'extreme_arcs'
    assert reg['hull_check']['outside'] == 0
    n = 2001
    z1s, z2s = np.linspace(1.1, 1.8, n), np.linspace(1.5, 2.4, n)
    edge = (
        [excavator_k(p, 1.1, z)[1] for z in z2s]
        + [excavator_k(p, z, 2.4)[1] for z in z1s]
        + [excavator_k(p, 1.8, z)[1] for z in z2s[::-1]]
        + [excavator_k(p, z, 1.5)[1] for z in z1s[::-1]]
    )
    xs, ys = np.array([q.real for q in edge]), np.array([q.imag for q in edge])
    area = 0.5 * abs(np.dot(xs, np.roll(ys, -1)) - np.dot(ys, np.roll(xs, -1)))
    assert reg['area'] == pytest.approx(area, rel=2e-3)
    # to the last digits: the exact integral of x dy - y dx along the four circular arcs (K
    # about O4 with Z2 held; about D, which Z1 holds, at radius DK), from their end angles
    # (unwrapped along the arc's construction); the chords alone fell short by 1.1e-5 of it,
    # and the largest x of the samples by 7e-6 m (an outside reviewer's finds)
    dk = abs(p['K'] - p['D'])
    exact, largest_x = 0.0, -math.inf
    for held, value, sweep in (
        ('Z1', 1.1, z2s),
        ('Z2', 2.4, z1s),
        ('Z1', 1.8, z2s[::-1]),
        ('Z2', 1.5, z1s[::-1]),
    ):
        ks = [excavator_k(p, value, z) if held == 'Z1' else excavator_k(p, z, value) for z in sweep]
        centre = ks[0][0] if held == 'Z1' else p['O4']  # D stays where Z1 holds it
        radius = dk if held == 'Z1' else abs(ks[0][1] - p['O4'])
        turns = np.unwrap([cmath.phase(k - centre) for _, k in ks])
        a0, a1 = float(turns[0]), float(turns[-1])
        exact += radius**2 * (a1 - a0) + radius * (
            centre.real * (math.sin(a1) - math.sin(a0))
            - centre.imag * (math.cos(a1) - math.cos(a0))
        )
        # its largest x: the circle's rightmost point where the arc passes angle 0 (mod 2 pi)
        lo, hi = sorted((a0, a1))
        passes = math.floor(hi / (2 * math.pi)) * 2 * math.pi >= lo
        top = centre.real + radius if passes else -math.inf
        largest_x = max(largest_x, top, *(k.real for _, k in ks))
    exact = 0.5 * abs(exact)
    assert reg['area'] == pytest.approx(exact, rel=1e-7), (reg['area'], exact)
    assert reg['extent'][0][1] == pytest.approx(largest_x, rel=1e-7)
    # from the fewest samples too (3, each extreme refined by solving; from 2 samples per
    # actuator the x extent had been 4 mm short at J: 2 is refused)
    few = motion.reachable_region(mech, 'K', actuators=['Z1', 'Z2'], samples_per_actuator=3)
    assert few['extent'][0][1] == pytest.approx(largest_x, rel=1e-9)


def test_excavator_bin_tilt_about_the_lip_stops_where_k_meets_the_zone_edge():
    """Seed 003 example 6, third part: with the lip L held, the bin turns about L, K moving on the
    circle about L of radius LK, until K reaches the boundary of its zone (K3). Turning clockwise
    the package stops at CB = min, i.e. on the arc about O4 of radius |O4K|(Z1, CB = 1.5): the
    rotation is the angle about L from K to the meeting point of those two circles, and the throws
    there are those of the construction."""
    mech = load('excavator')
    p = {k: c(v) for k, v in mech.points.items()}
    res = motion.max_tilt(mech, 'L', 'bucket')
    assert res['ok']
    assert 'Z2' in res['reason']['min'] and 'minimum' in res['reason']['min']
    _, K_any = excavator_k(p, 1.5, 1.5)
    r_min = abs(K_any - p['O4'])  # zone edge CB = 1.5: circle about O4
    lk = abs(p['K'] - p['L'])
    cands = [meet(p['L'], lk, p['O4'], r_min, s) for s in (1, -1)]
    turns = [cmath.phase((q - p['L']) / (p['K'] - p['L'])) for q in cands]
    clockwise = [-t for t in turns if t < 0]
    assert res['tilt_down'] == pytest.approx(min(clockwise), abs=1e-9)
    K3 = cands[turns.index(-min(clockwise))]
    D3 = meet(
        p['O4'], abs(p['D'] - p['O4']), K3, abs(p['D'] - p['K']), side_of(p['O4'], p['K'], p['D'])
    )
    A3 = transfer(p['O4'], p['D'], p['O4'], D3, p['A'])
    assert res['inputs_at']['min']['Z1'] == pytest.approx(abs(A3 - p['O2']), abs=1e-8)
    assert 1.1 <= abs(A3 - p['O2']) <= 1.8


def test_excavator_bin_tilt_about_the_lip_at_l2_with_only_the_seeds_ranges():
    """Seed 003 example 6, third part as the lecture states it: the lip held at L2 (the README's
    1.867934199, -0.169618455, the bin at -0.79323 rad), the bin turned until K reaches the edge
    of its zone, the four arcs of the Z1 and Z2 ranges, the only ranges the seed gives. The
    scene's own Z3 range stops the bin first both ways (an outside reviewer's find: the README
    called that the seed's answer); with Z3's limits lifted (linkage range --without-limits Z3)
    the tilts are the construction's: K on the circle about L2 (radius LK) meets an arc."""
    mech = load('excavator')
    p = {k: c(v) for k, v in mech.points.items()}
    L2, start = complex(1.867934199, -0.169618455), -0.79323
    K0 = L2 + cmath.exp(1j * (start - mech.links['bucket'].angle_ref)) * (p['K'] - p['L'])
    lk, dk = abs(p['K'] - p['L']), abs(p['K'] - p['D'])
    ups, downs = [], []
    for held, value, sweep in (
        ('Z1', 1.1, (1.5, 1.95, 2.4)),
        ('Z1', 1.8, (1.5, 1.95, 2.4)),
        ('Z2', 1.5, (1.1, 1.45, 1.8)),
        ('Z2', 2.4, (1.1, 1.45, 1.8)),
    ):
        on = [excavator_k(p, value, z) if held == 'Z1' else excavator_k(p, z, value) for z in sweep]
        centre = on[0][0] if held == 'Z1' else p['O4']  # D stays where Z1 holds it
        radius = dk if held == 'Z1' else abs(on[0][1] - p['O4'])
        a0 = cmath.phase(on[0][1] - centre)
        mid, end = ((cmath.phase(k - centre) - a0) % (2 * math.pi) for _, k in on[1:])
        for side in (1, -1):
            q = meet(L2, lk, centre, radius, side)
            if abs(abs(q - centre) - radius) > 1e-9 or abs(abs(q - L2) - lk) > 1e-9:
                continue  # the circles do not meet
            at = (cmath.phase(q - centre) - a0) % (2 * math.pi)
            if not (at <= end if mid < end else at >= end):  # not on the arc's stretch
                continue
            turn = cmath.phase((q - L2) / (K0 - L2))
            (ups if turn > 0 else downs).append(abs(turn))
    hold = (L2.real, L2.imag)
    lifted = motion.max_tilt(
        motion.limits_lifted(mech, ['Z3']), 'L', 'bucket', hold_point=hold, start_angle=start
    )
    assert lifted['ok']
    assert lifted['tilt_up'] == pytest.approx(min(ups), abs=1e-9)
    assert lifted['tilt_down'] == pytest.approx(min(downs), abs=1e-9)
    scene = motion.max_tilt(mech, 'L', 'bucket', hold_point=hold, start_angle=start)
    assert 'Z3' in scene['reason']['max'] and 'Z3' in scene['reason']['min']
    assert scene['tilt_up'] < min(ups) and scene['tilt_down'] < min(downs)
