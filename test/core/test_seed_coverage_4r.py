"""Claims of seeds 000 and 002 (/work/shared/seeds) that no other test file checks: the loop
closure of the 4R chain and its tan-half-angle solution (the two assembly modes), forward and
inverse kinematics of the 4R chain, the theta4(theta2) curves of the Grashof classes (assembly
modes and circuits), and the slotted-lever quick-return mechanism's two loop-closure equations.

Every oracle is independent of the solver: the seeds' own formulas (tan-half-angle quadratics,
cosine rules, circle intersections), never the package's answer fed back to itself.
"""

import cmath
import math

import numpy as np
import pytest
from scenes import four_bar, load
from seed_coverage_helpers import TWO_PI, c, circ, meet

from linkage_ros.core import motion
from linkage_ros.core.solver import Solver

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
    # the rocker's range: its extremes where crank and coupler are in line, |O2 B| = l3 +- l2
    # (the cosine rule in O2 O4 B, O4 at (l1, 0))
    lo, hi = sorted(
        math.acos((d * d - l1 * l1 - l4 * l4) / (2 * l1 * l4)) for d in (l3 - l2, l3 + l2)
    )
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
