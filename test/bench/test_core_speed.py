"""The hand-written baselines of the core-speed bench answer what the solver answers (a ratio
against a baseline that computes something else would mean nothing)."""

from __future__ import annotations

import math

import numpy as np

from linkage_ros.bench.core_speed import (
    core_speed_targets,
    four_bar_dims,
    math_four_bar,
    numpy_four_bar,
    textbook_closure,
)
from linkage_ros.bench.tradeoff import load_scene
from linkage_ros.core.solver import Solver


def test_the_math_and_numpy_four_bars_are_the_solvers_four_bar():
    mech = load_scene('four_bar')
    dims = four_bar_dims(mech)
    solver = Solver(mech)
    angles = np.linspace(-3.0, 3.0, 13)
    t3n, t4n, xn, yn = numpy_four_bar(angles, **dims)
    for k, t in enumerate(angles.tolist()):
        r = solver.solve({'crank': t})
        assert r.success
        t3, t4, x, y = math_four_bar(t, **dims)
        # theta3 is the direction A -> B; the coupler link's angle is measured from its drawing
        a, b = r.points['A'], r.points['B']
        assert abs(math.remainder(t3 - math.atan2(b[1] - a[1], b[0] - a[0]), 2 * math.pi)) < 1e-12
        o4 = r.points['O4']
        assert abs(math.remainder(t4 - math.atan2(b[1] - o4[1], b[0] - o4[0]), 2 * math.pi)) < 1e-12
        assert math.dist((x, y), r.points['P']) < 1e-12 * mech.length_scale
        np.testing.assert_allclose(
            (t3n[k], t4n[k], xn[k], yn[k]), (t3, t4, x, y), rtol=0, atol=1e-14
        )
        # the textbook closure vanishes at the answer
        assert np.max(np.abs(textbook_closure(dims)(np.array([t3, t4]), t))) < 1e-15


def test_the_targets_say_met_or_not_with_the_numbers():
    core = {
        'scalar': {
            'us': {
                'math four-bar': 1.0,
                'Solver.solve four_bar': 10.0,
                'Solver.solve excavator': 30.0,
            },
            'four_bar_vs_math': 10.0,
            'excavator_vs_four_bar': 3.0,
            'max_point_diff_m': 0.0,
        },
        'newton': {
            'us': {'scipy root (2 equations)': 25.0, 'Solver newton': 50.0},
            'speedup_vs_scipy': 0.5,
            'max_angle_diff_rad': 0.0,
        },
        'batch': {
            'n': 100,
            'us_per_input': {
                'numpy four-bar': 0.05,
                'solve_batch four_bar': 0.08,
                'solve_batch excavator': 0.5,
            },
            'throughput_vs_numpy': 0.625,
            'excavator_vs_four_bar': 6.25,
            'max_point_diff_m': 0.0,
        },
    }
    got = [(t['met'], t['measured'].split(' ')[0]) for t in core_speed_targets(core)]
    assert got == [
        (False, '10.0x'),
        (True, '3.0x'),
        (False, '0.50x'),
        (True, '0.62x'),
        (False, '6.2x'),
    ]
