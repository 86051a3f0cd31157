"""Two points of one link as a target (seed 003, example 6: "determine the location of all the
moving revolute pairs when the hinges J and K occupy the locations J2 and K2").

The oracle is the lecture's own construction, written here apart from the core: the bin is
moved rigidly so that J and K land on J2 and K2 (tracing paper), which places L; D2 is then on
the circle about O4 (the boom) and on the circle about K2 (the stick), and the answer's D must
be one of the two intersections. Positions come from forward solves of in-limit cylinder
lengths, so the source configuration is a solution.
"""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from scenes import load

from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings


@pytest.fixture(scope='module')
def excavator():
    return load('excavator')


def _in_limit_configurations(mech, n, seed):
    fwd = Solver(mech, branch='reference')
    rng = random.Random(seed)
    out = []
    while len(out) < n:
        cmd = {
            a: rng.uniform(act.min, act.max) for a, act in mech.actuators.items()
        }  # every excavator actuator is a cylinder with limits
        r = fwd.solve(cmd, commit=False)
        if r.success and r.branch == fwd.solve(fwd.reference_values(), commit=False).branch:
            out.append((cmd, r))
    return out


def _rigid_move(ref_a, ref_b, a, b):
    """The rotation angle and the map of a rigid motion taking ref_a, ref_b to a, b."""
    ref_a, ref_b, a, b = (np.asarray(v, float) for v in (ref_a, ref_b, a, b))
    turn = math.atan2(*(b - a)[::-1]) - math.atan2(*(ref_b - ref_a)[::-1])
    c, s = math.cos(turn), math.sin(turn)
    rot = np.array([[c, -s], [s, c]])
    return turn, lambda p: a + rot @ (np.asarray(p, float) - ref_a)


def _circles(c0, r0, c1, r1):
    """Both intersections of two circles (independent of the core's dyad code)."""
    c0, c1 = np.asarray(c0, float), np.asarray(c1, float)
    d = float(np.linalg.norm(c1 - c0))
    a = (r0 * r0 - r1 * r1 + d * d) / (2 * d)
    h = math.sqrt(max(r0 * r0 - a * a, 0.0))
    u = (c1 - c0) / d
    m = c0 + a * u
    perp = np.array([-u[1], u[0]])
    return m + h * perp, m - h * perp


def test_bin_by_hinges_j_and_k_is_the_lecture_construction(excavator):
    mech = excavator
    P = {k: np.asarray(v, float) for k, v in mech.points.items()}
    scale = mech.length_scale
    solver = Solver(mech, knowns=['point:J', 'point:K'])
    assert solver.point_pairs and solver.point_pairs[0].link == 'bucket'
    for cmd, src in _in_limit_configurations(mech, 12, 'hinges'):
        j2, k2 = src.points['J'], src.points['K']
        e = Engine(mech, EngineSettings(branch='continuous'))
        r = e.target({'point:J': j2, 'point:K': k2})
        assert r.success, r.reason
        # tracing paper: the bin's other point L follows the rigid motion J, K -> J2, K2
        turn, move = _rigid_move(P['J'], P['K'], j2, k2)
        assert np.linalg.norm(np.asarray(r.points['L']) - move(P['L'])) < 1e-9 * scale
        assert (
            abs(
                math.remainder(
                    r.links['bucket'] - (mech.links['bucket'].angle_ref + turn), 2 * math.pi
                )
            )
            < 1e-12
        )
        # D2 on the circle about O4 (boom) and on the circle about K2 (stick)
        d_options = _circles(
            P['O4'],
            float(np.linalg.norm(P['D'] - P['O4'])),
            k2,
            float(np.linalg.norm(P['D'] - P['K'])),
        )
        got_d = np.asarray(r.points['D'])
        assert min(np.linalg.norm(got_d - o) for o in d_options) < 1e-9 * scale
        # and the whole mechanism is the configuration the hinges came from (same mode)
        for p in mech.points:
            assert math.dist(r.points[p], src.points[p]) < 1e-9 * scale, p
        for a, v in cmd.items():
            assert abs(r.inputs[a] - v) < 1e-9 * scale, a


def test_hinges_whose_distance_is_not_the_bins_are_refused_with_both_distances(excavator):
    mech = excavator
    ((_, src),) = _in_limit_configurations(mech, 1, 'bad-distance')
    j2, k2 = np.asarray(src.points['J']), np.asarray(src.points['K'])
    true_d = float(np.linalg.norm(np.asarray(mech.points['K']) - np.asarray(mech.points['J'])))
    solver = Solver(mech, knowns=['point:J', 'point:K'])
    for stretch in (1e-3, -0.05, 1e-6):
        k_bad = j2 + (k2 - j2) * (1 + stretch / true_d)
        r = solver.solve({'point:J': tuple(j2), 'point:K': tuple(k_bad)})
        assert not r.success
        assert f'{true_d:.9g} m apart' in r.reason, r.reason
        assert f'the target puts them {true_d + stretch:.9g} m apart' in r.reason, r.reason
        assert '--tol, the tolerance parameter' in r.reason, r.reason  # (seed 003 ex. 6 reads
        # J2 and K2 off a drawing)
    # within the solve tolerance the pair is accepted (a rounding of the given coordinates)
    k_ok = j2 + (k2 - j2) * (1 + 1e-13)
    assert solver.solve({'point:J': tuple(j2), 'point:K': tuple(k_ok)}).success


def test_node_names_for_points_and_mixed_targets(excavator):
    """`<point>.x`, `<point>.y` on ~/target: two hinges, or a point plus a link angle."""
    mech = excavator
    ((cmd, src),) = _in_limit_configurations(mech, 1, 'names')
    e = Engine(mech, EngineSettings(branch='continuous'))
    (jx, jy), (kx, ky) = src.points['J'], src.points['K']
    r = e.target({'J.x': jx, 'J.y': jy, 'K.x': kx, 'K.y': ky})
    assert r.success and all(abs(r.inputs[a] - v) < 1e-9 for a, v in cmd.items())
    (lx, ly) = src.points['L']
    e = Engine(mech, EngineSettings(branch='continuous'))
    r = e.target({'L.x': lx, 'L.y': ly, 'bucket': src.links['bucket']})
    assert r.success and math.dist(r.points['L'], (lx, ly)) < 1e-9 * mech.length_scale
    # one coordinate is a known of its own: J.x and K place the bin, J.y is solved
    e = Engine(mech, EngineSettings(branch='continuous'))
    r = e.target({'J.x': jx, 'K.x': kx, 'K.y': ky})
    assert r.success, r.reason
    assert math.dist(r.points['J'], (jx, jy)) < 1e-9 * mech.length_scale
    assert all(abs(r.inputs[a] - v) < 1e-9 for a, v in cmd.items())
    before = e.last
    for bad, why in (
        ({'J.x': jx, 'K.x': kx}, 'degree(s) of freedom'),
        ({'Q.x': 1.0, 'Q.y': 2.0, 'bucket': 0.1}, "unknown name 'Q.x'"),
        ({'J.z': 1.0, 'J.x': jx, 'J.y': jy}, "unknown name 'J.z'"),
    ):
        r = e.target(bad)
        assert not r.success and why in r.reason, r.reason
        assert e.last is before


def test_batch_of_hinge_pairs_equals_one_by_one(excavator):
    mech = excavator
    confs = _in_limit_configurations(mech, 6, 'batch')
    solver = Solver(mech, knowns=['point:J', 'point:K'], method='closed_form', branch='reference')
    cols = {
        'point:J': np.array([src.points['J'] for _, src in confs]),
        'point:K': np.array([src.points['K'] for _, src in confs]),
    }
    batch = solver.solve_batch(cols)
    for i, (_, src) in enumerate(confs):
        one = solver.solve({'point:J': src.points['J'], 'point:K': src.points['K']}, commit=False)
        row = batch.row(i, solver)
        assert one.success == row.success
        if one.success:
            for p in mech.points:
                assert math.dist(one.points[p], row.points[p]) < 1e-12 * mech.length_scale
    cols['point:K'] = cols['point:K'].copy()
    cols['point:K'][3] += 0.01
    with pytest.raises(ValueError, match='row 3: point:J and point:K are both on link'):
        solver.solve_batch(cols)
