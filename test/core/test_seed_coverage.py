"""Claims of the four seed lectures (/work/shared/seeds) that no other test file checks.

Seeds: 000 analytical displacement analysis (loop closure, the tan-half-angle solution of the
4R, the theta4(theta2) curves of the Grashof classes, the slotted-lever quick-return loops),
001 exact straight-line mechanisms (Scott-Russell, the principle of inversion, Peaucellier and
Hart inversors), 002 forward and inverse kinematics of the 4R chain, 003 graphical displacement
analysis (front-end loader, 3R-1P, earth-moving machinery).

Every oracle is independent of the solver: the seeds' own formulas and constructions written
out here (tan-half-angle quadratics, circle intersections, "tracing paper" rigid transfers,
cosine rules, the inversion of a circle), never the package's answer fed back to itself.
"""

import cmath
import math

import numpy as np
import pytest
from scenes import four_bar, load, raw

from linkage_ros.core import motion
from linkage_ros.core.errors import PlanError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

TWO_PI = 2.0 * math.pi
EXACT = 1e-12  # closed-form geometry, fraction of the length scale


def c(p):
    return complex(float(p[0]), float(p[1]))


def cross(u, v):
    return u.real * v.imag - u.imag * v.real


def circ(a, b):
    """Distance of two angles on the circle."""
    return abs(math.remainder(a - b, TWO_PI))


def meet(c1, r1, c2, r2, side):
    """Intersection of the circles (c1, r1) and (c2, r2) on the given side (+1: left of c1->c2).
    The compass construction of the seeds, written out."""
    d = abs(c2 - c1)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = math.sqrt(max(r1 * r1 - a * a, 0.0))
    u = (c2 - c1) / d
    return c1 + u * complex(a, side * h)


def side_of(p1, p2, p3):
    """+1 if p3 is left of p1->p2, -1 if right."""
    return 1 if cross(p2 - p1, p3 - p1) > 0 else -1


def transfer(ref_a, ref_b, new_a, new_b, ref_x):
    """Tracing paper: the point of a rigid body at ref_x, when the body's points ref_a, ref_b
    have moved to new_a, new_b."""
    rot = (new_b - new_a) / (ref_b - ref_a)
    return new_a + rot / abs(rot) * (ref_x - ref_a)


# ================================================================================================
# Seed 000 / 002: loop closure of the 4R chain and its tan-half-angle solution
# ================================================================================================


def seed000_roots(l1, l2, l3, l4, t2):
    """Seed 000's solution, in its frame (O2 at the origin, vector l1 = O4->O2 along +x, loop
    l1 + l2 + l3 - l4 = 0):
        a sin(t4) + b cos(t4) = c,  a = sin t2,  b = l1/l2 + cos t2,
        c = (l1^2 + l2^2 - l3^2 + l4^2) / (2 l2 l4) + (l1/l4) cos t2,
        tan(t4/2) = (a +- sqrt(a^2 + b^2 - c^2)) / (b + c),
    and for theta3 the same with l4 -> -l3, l3 -> -l4 (the seed's substitution rule), i.e.
        c' = -(l1^2 + l2^2 + l3^2 - l4^2) / (2 l2 l3) - (l1/l3) cos t2.
    (The transcript reads c' aloud garbled; this is what its substitution rule gives.)"""
    a, b = math.sin(t2), l1 / l2 + math.cos(t2)
    cc = (l1 * l1 + l2 * l2 - l3 * l3 + l4 * l4) / (2 * l2 * l4) + l1 / l4 * math.cos(t2)
    cp = -(l1 * l1 + l2 * l2 + l3 * l3 - l4 * l4) / (2 * l2 * l3) - l1 / l3 * math.cos(t2)
    t4 = [2 * math.atan2(a + s * math.sqrt(a * a + b * b - cc * cc), b + cc) for s in (1, -1)]
    t3 = [2 * math.atan2(a + s * math.sqrt(a * a + b * b - cp * cp), b + cp) for s in (1, -1)]
    return t3, t4


@pytest.mark.parametrize(
    'lengths',
    [
        (0.30, 0.10, 0.25, 0.20),  # shipped four_bar.yaml
        (0.10, 0.25, 0.30, 0.20),  # double-crank scene
        (0.30, 0.20, 0.25, 0.22),
    ],
)  # non-Grashof scene
def test_seed000_tan_half_angle_roots_are_the_two_assembly_modes(lengths):
    """Seed 000: 'we get two roots for tan theta4/2 ... two values of theta4 and two values of
    theta3', one per mode of assembly. Built in the seed's own frame (O4 at (-l1, 0):
    ground_angle pi), the package's two modes are exactly the two roots, and each pair satisfies
    the seed's two scalar loop-closure equations."""
    l1, l2, l3, l4 = lengths
    mech = four_bar(l1, l2, l3, l4, ground_angle=math.pi, input=math.pi - 1.0)
    solver = Solver(mech)
    checked = 0
    for t2 in np.linspace(-math.pi, math.pi, 73):
        t2 = float(t2)
        a, b = math.sin(t2), l1 / l2 + math.cos(t2)
        cc = (l1 * l1 + l2 * l2 - l3 * l3 + l4 * l4) / (2 * l2 * l4) + l1 / l4 * math.cos(t2)
        disc = a * a + b * b - cc * cc
        results = solver.solve_all({'crank': t2})
        ok = [r for r in results if r.success]
        if disc < 1e-9:  # no real root (or a toggle): the package must not assemble
            assert disc > -1e-9 or not ok
            continue
        t3s, t4s = seed000_roots(l1, l2, l3, l4, t2)
        assert len(ok) == 2
        got = [(r.links['coupler'], r.links['rocker']) for r in ok]
        for t3, t4 in got:
            # seed 000 equations (1) and (2)
            assert abs(l1 + l2 * math.cos(t2) + l3 * math.cos(t3) - l4 * math.cos(t4)) <= 1e-12
            assert abs(l2 * math.sin(t2) + l3 * math.sin(t3) - l4 * math.sin(t4)) <= 1e-12
        assert sorted(min(circ(t4, r) for t4 in t4s) for _, r in got)[-1] <= 1e-9
        assert sorted(min(circ(t3, r) for t3 in t3s) for r, _ in got)[-1] <= 1e-9
        assert circ(got[0][1], got[1][1]) > 1e-6  # two distinct modes
        checked += 1
    assert checked >= 30


def test_seed002_forward_and_inverse_kinematics_of_the_4r_chain():
    """Seed 002, in the package's frame (P = l2 (cos t2, sin t2), Q = (l1 + l4 cos t4,
    l4 sin t4), l3^2 = |Q - P|^2): forward, A sin t4 + B cos t4 = C with two roots
    (A +- sqrt(A^2 + B^2 - C^2)) / (B + C) and theta3 = atan2(Qy - Py, Qx - Px); inverse, the
    same equation rearranged for theta2 given theta4, again two roots (two assembly modes)."""
    mech = load('four_bar')
    p = mech.points
    l1, l2 = abs(c(p['O4']) - c(p['O2'])), abs(c(p['A']) - c(p['O2']))
    l3, l4 = abs(c(p['B']) - c(p['A'])), abs(c(p['B']) - c(p['O4']))
    fwd = Solver(mech)
    for t2 in np.linspace(0.0, TWO_PI, 37)[:-1]:
        t2 = float(t2)
        A = -2 * l2 * l4 * math.sin(t2)
        B = 2 * l4 * (l1 - l2 * math.cos(t2))
        C = l3 * l3 - l4 * l4 - l1 * l1 - l2 * l2 + 2 * l1 * l2 * math.cos(t2)
        roots = [2 * math.atan2(A + s * math.sqrt(A * A + B * B - C * C), B + C) for s in (1, -1)]
        ok = [r for r in fwd.solve_all({'crank': t2}) if r.success]
        assert len(ok) == 2
        for r in ok:
            t4 = r.links['rocker']
            assert min(circ(t4, x) for x in roots) <= 1e-10
            P = l2 * cmath.exp(1j * t2)
            Q = l1 + l4 * cmath.exp(1j * t4)
            assert circ(r.links['coupler'], math.atan2(Q.imag - P.imag, Q.real - P.real)) <= 1e-10
    inv = Solver(mech, knowns=['rocker'])  # the output link's angle is given
    lo, hi = 1.633337088591388, 2.6810992285307336  # rocker range (toggles), see test_analysis
    for t4 in np.linspace(lo + 1e-3, hi - 1e-3, 25):
        t4 = float(t4)
        Q = l1 + l4 * cmath.exp(1j * t4)
        A, B = 2 * l2 * Q.imag, 2 * l2 * Q.real
        C = l2 * l2 + abs(Q) ** 2 - l3 * l3
        roots = [2 * math.atan2(A + s * math.sqrt(A * A + B * B - C * C), B + C) for s in (1, -1)]
        ok = [r for r in inv.solve_all({'rocker': t4}) if r.success]
        assert len(ok) == 2
        found = sorted(r.inputs['crank'] for r in ok)
        for x in roots:
            assert min(circ(x, f) for f in found) <= 1e-10
        assert circ(found[0], found[1]) > 1e-6


# ================================================================================================
# Seed 000 / 002: theta4(theta2) curves of the Grashof classes, assembly modes and circuits
# ================================================================================================


def theta4_branches(l1, l2, l3, l4, t2):
    """Both rocker angles at crank angle t2 (NaN where the dyad does not close): B from the
    circles (A, l3) and (O4, l4), on either side of A->O4."""
    A = l2 * cmath.exp(1j * t2)
    O4 = complex(l1, 0.0)
    d = abs(O4 - A)
    if not abs(l3 - l4) < d < l3 + l4:
        return math.nan, math.nan
    out = []
    for side in (1, -1):
        B = meet(A, l3, O4, l4, side)
        out.append(cmath.phase(B - O4))
    return tuple(out)


def grashof_oracle(l1, l2, l3, l4):
    s, p, q, lng = sorted((l1, l2, l3, l4))
    return s + lng < p + q


SCENE_LENGTHS = {
    'four_bar': (0.30, 0.10, 0.25, 0.20),
    'four_bar_double_crank': (0.10, 0.25, 0.30, 0.20),
    'four_bar_grashof_double_rocker': (0.30, 0.20, 0.10, 0.25),
    'four_bar_non_grashof': (0.30, 0.20, 0.25, 0.22),
}
SCENE_CLASS = {
    'four_bar': 'crank-rocker',
    'four_bar_double_crank': 'double-crank',
    'four_bar_grashof_double_rocker': 'grashof-double-rocker',
    'four_bar_non_grashof': 'triple-rocker',
}


@pytest.mark.parametrize('stem', sorted(SCENE_LENGTHS))
def test_grashof_class_scenes_have_their_documented_dimensions_and_class(stem):
    """The four theta4(theta2) plots of seed 000, one shipped scene each."""
    from linkage_ros.core.analysis import grashof_class

    mech = load(stem)
    p = mech.points
    got = (
        abs(c(p['O4']) - c(p['O2'])),
        abs(c(p['A']) - c(p['O2'])),
        abs(c(p['B']) - c(p['A'])),
        abs(c(p['B']) - c(p['O4'])),
    )
    assert got == pytest.approx(SCENE_LENGTHS[stem], rel=1e-14)
    lengths = SCENE_LENGTHS[stem]
    s = sorted(lengths)
    assert grashof_oracle(*lengths) == (stem != 'four_bar_non_grashof')
    shortest = lengths.index(s[0])
    oracle = (
        'triple-rocker'
        if not grashof_oracle(*lengths)
        else {0: 'double-crank', 1: 'crank-rocker', 2: 'grashof-double-rocker', 3: 'crank-rocker'}[
            shortest
        ]
    )
    assert oracle == SCENE_CLASS[stem] == grashof_class(*lengths)


@pytest.mark.parametrize('stem', ['four_bar', 'four_bar_double_crank'])
def test_grashof_crank_curves_are_two_separate_modes_and_a_drive_stays_in_one(stem):
    """Seed 000: for a Grashof crank-rocker or double-crank, theta2 goes from 0 to 2 pi on each
    of two curves theta4(theta2) (two modes of assembly) that never cross; 'if we are starting
    on one of the curves you will always remain there'. Crank-rocker: theta4 stays between a
    minimum and a maximum; double-crank: theta4 also turns through 2 pi per turn."""
    l1, l2, l3, l4 = SCENE_LENGTHS[stem]
    mech = load(stem)
    t2 = np.linspace(0.0, 2 * TWO_PI, 1441)  # two full turns of the crank
    oracle = np.array([theta4_branches(l1, l2, l3, l4, float(t)) for t in t2])
    assert np.isfinite(oracle).all()  # every crank angle assembles, both modes
    gap = np.abs(np.remainder(oracle[:, 0] - oracle[:, 1] + math.pi, TWO_PI) - math.pi)
    assert gap.min() > 0.1  # the two curves never meet
    drive = Solver(mech)  # continuous: the way it moves
    got = np.array([drive.solve({'crank': float(t)}).links['rocker'] for t in t2])
    ref_mode = 0 if circ(got[0], oracle[0, 0]) < 1e-9 else 1
    assert np.all(
        np.abs(np.remainder(got - oracle[:, ref_mode] + math.pi, TWO_PI) - math.pi) <= 1e-10
    )
    turn = np.unwrap(got)
    if stem == 'four_bar':
        assert turn.max() - turn.min() < math.pi  # a rocker: bounded
        assert abs(turn[-1] - turn[0]) <= 1e-10
    else:
        assert abs(abs(turn[-1] - turn[0]) - 2 * TWO_PI) <= 1e-9  # turns fully, twice
    # the package lists both modes at every angle, and the other one is the other curve
    other = Solver(mech, branch='-' if ref_mode == 0 else '+')
    for i in range(0, t2.size, 60):
        r = other.solve({'crank': float(t2[i])})
        assert circ(r.links['rocker'], oracle[i, 1 - ref_mode]) <= 1e-10


def rocking_range_oracle(l1, l2, l3, l4):
    """Crank angles where the dyad A-B-O4 toggles: |A - O4| = l3 + l4 or |l3 - l4| (cosine rule),
    each as an angle in [0, pi] (the ranges are symmetric about the ground line)."""
    out = []
    for d in (l3 + l4, abs(l3 - l4)):
        cosv = (l1 * l1 + l2 * l2 - d * d) / (2 * l1 * l2)
        if -1 < cosv < 1:
            out.append(math.acos(cosv))
    return sorted(out)


def output_range_oracle(l1, l2, l3, l4):
    """Rocker angles phi from O4->O2 where crank and coupler are collinear: |B - O2| = l2 + l3
    or |l2 - l3| (cosine rule), in [0, pi]."""
    out = []
    for d in (l2 + l3, abs(l2 - l3)):
        cosv = (l1 * l1 + l4 * l4 - d * d) / (2 * l1 * l4)
        if -1 < cosv < 1:
            out.append(math.acos(cosv))
    return sorted(out)


def test_grashof_double_rocker_moves_on_one_of_two_separate_loops():
    """Seed 000: 'Grashof double-rocker, then again we have two loops ... neither theta2 nor
    theta4 can make complete rotation ... you can never pass on from one mode of assembly to
    the other'. The crank's circuit is one toggle-to-toggle interval in the upper half-plane, its
    mirror is the other loop; the rocker's range is that loop's (both dyad signs, met at the
    toggles) and never the union with the mirror loop."""
    l1, l2, l3, l4 = SCENE_LENGTHS['four_bar_grashof_double_rocker']
    mech = load('four_bar_grashof_double_rocker')
    alpha, beta = rocking_range_oracle(l1, l2, l3, l4)  # 0.460493, 1.508256
    info = motion.actuator_range(mech, 'crank')
    assert (info['min'], info['max']) == pytest.approx((alpha, beta), abs=1e-9)
    assert sorted(info['toggles']) == pytest.approx([alpha, beta], abs=1e-9)
    phi_near, phi_far = output_range_oracle(l1, l2, l3, l4)  # rocker angle from O4->O2
    lo4, hi4 = motion.oscillation_range(mech, 'rocker')
    assert (lo4, hi4) == pytest.approx((math.pi - phi_far, math.pi - phi_near), abs=1e-9)
    # the mirror loop exists (the geometry closes there) but the shipped crank cannot get there
    assert all(math.isfinite(v) for v in theta4_branches(l1, l2, l3, l4, -1.0))
    assert not Solver(mech).solve({'crank': -1.0}).success
    assert Solver(motion.without_limits(mech)).solve({'crank': -1.0}).success
    # between the loops (theta2 = 0 and pi) nothing assembles
    for t in (0.0, 0.3, math.pi, -0.3):
        assert all(math.isnan(v) for v in theta4_branches(l1, l2, l3, l4, t))


def test_non_grashof_has_one_circuit_that_takes_up_the_mirror_image():
    """Seed 000: a non-Grashof linkage 'has to be a double-rocker ... there is only one curve,
    because there is only one mode of assembly ... the mirror image configuration can be taken
    up by the same assembly'. The crank range is one interval symmetric about the ground line
    between two toggles, and following the motion through the toggles the rocker sweeps the whole
    range set by crank and coupler in line, which contains every pose's mirror image (theta4 ->
    -theta4). Were the circuit one sign only, the rocker range would stop at theta4 = 3.363 rad."""
    l1, l2, l3, l4 = SCENE_LENGTHS['four_bar_non_grashof']
    mech = load('four_bar_non_grashof')
    (beta,) = rocking_range_oracle(l1, l2, l3, l4)  # only l3 + l4 binds: 2.430271
    info = motion.actuator_range(mech, 'crank')
    assert (info['min'], info['max']) == pytest.approx((-beta, beta), abs=1e-9)
    (phi,) = output_range_oracle(l1, l2, l3, l4)  # only l2 + l3 binds: 2.077853
    lo4, hi4 = motion.oscillation_range(mech, 'rocker')
    assert (lo4, hi4) == pytest.approx((math.pi - phi, math.pi + phi), abs=1e-9)
    # every pose's mirror image is a pose of the same chain: same crank interval, theta4 -> -theta4
    solver = Solver(mech, branch='reference')
    for t2 in np.linspace(-beta + 1e-3, beta - 1e-3, 41):
        both = [r.links['rocker'] for r in solver.solve_all({'crank': float(t2)}) if r.success]
        mirror = [r.links['rocker'] for r in solver.solve_all({'crank': -float(t2)}) if r.success]
        assert len(both) == len(mirror) == 2
        for t4 in both:
            assert min(circ(-t4, m) for m in mirror) <= 1e-10


# ================================================================================================
# Seed 000: the slotted-lever quick-return mechanism's two loop-closure equations
# ================================================================================================


def test_quick_return_reports_the_four_unknowns_of_the_seed_loops():
    """Seed 000: two independent loops, O2-A-O4 (l2 = l1 + s4) and O2-A-B-C-D (lever, link 5 and
    the tool's slide s6), four scalar unknowns theta4, theta5, s4, s6 for a given theta2. The
    package's reported lever and rod angles and its two slide values satisfy both vector
    equations, written with the lengths measured from the scene's reference pose."""
    mech = load('quick_return')
    p = {k: c(v) for k, v in mech.points.items()}
    r = abs(p['A'] - p['O2'])
    L = abs(p['B'] - p['O4'])
    l5 = abs(p['C'] - p['B'])
    solver = Solver(mech)
    for t2 in np.linspace(0.0, TWO_PI, 49):
        res = solver.solve({'crank': float(t2)})
        assert res.success
        t4, t5 = res.links['lever'], res.links['rod']
        s4, s6 = res.joints['slot'], res.joints['ram']
        # loop 1: O2A = O2O4 + O4A, with O4A = s4 along the lever
        loop1 = (p['O4'] - p['O2']) + s4 * cmath.exp(1j * t4)
        assert abs(r * cmath.exp(1j * t2) - loop1) <= 1e-12
        # loop 2: O2O4 + O4B + BC = O2D + DC, with DC = s6 along the ground line (+x)
        lhs = (p['O4'] - p['O2']) + L * cmath.exp(1j * t4) + l5 * cmath.exp(1j * t5)
        assert abs(lhs - ((p['D'] - p['O2']) + s6)) <= 1e-12
        assert 0 < s4 < L


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
        p['D'] + complex(-0.24, 0.06),
        p['D'] + complex(-0.10, -0.30),
        p['D'] + complex(-0.05, -0.50),
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
        (-0.03, 0.1),
        (0.05, 0.2),
        (0.1, 0.25),
        (0.25, 0.45),
        (0.45, 0.7),
        (0.7, 0.95),
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
