"""A point target out of reach is refused in the user's terms: where the point stops being
reachable on the straight way to the target (core.solver.reach), checked against the five-bar's
workspace edge written independently (the circle |P - O2| = l1 + l2 crossed by the line)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.reach import reach_edge
from linkage_ros.engine import Engine, EngineSettings

FIVE_BAR = {
    'name': 'five_bar',
    'points': {
        'O2': [0, 0],
        'O5': [0.3, 0],
        'A': [0.0, 0.15],
        'P': [0.15, 0.3],
        'B': [0.3, 0.15],
    },
    'links': {
        'ground': ['O2', 'O5'],
        'l1': ['O2', 'A'],
        'l2': ['A', 'P'],
        'l3': ['P', 'B'],
        'l4': ['O5', 'B'],
    },
    'actuators': {
        'a1': {'type': 'angle', 'link': 'l1', 'pivot': 'O2', 'toward': 'A'},
        'a2': {'type': 'angle', 'link': 'l4', 'pivot': 'O5', 'toward': 'B'},
    },
}


def outer_edge(p0, target, centre, reach):
    """Where the segment p0 -> target leaves the disk |X - centre| <= reach (p0 inside)."""
    dx, dy = target[0] - p0[0], target[1] - p0[1]
    fx, fy = p0[0] - centre[0], p0[1] - centre[1]
    a, b, c = dx * dx + dy * dy, 2 * (fx * dx + fy * dy), fx * fx + fy * fy - reach * reach
    s = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    return p0[0] + s * dx, p0[1] + s * dy


@pytest.mark.parametrize('target', [(0.15, 2.0), (-0.9, 0.8), (0.05, 1.1)])
def test_the_reach_edge_is_where_the_line_leaves_the_workspace(target):
    mech = Scene.from_dict(FIVE_BAR).mechanism
    here = Solver(mech).solve(Solver(mech).reference_values())
    solver = Solver(mech, knowns=['point:P'])
    assert not solver.solve({'point:P': target}, commit=False).success
    edge = reach_edge(solver, {'point:P': target}, here)
    assert edge is not None and edge.point == 'P'
    # the oracle: both chains stretched out bound P to two disks; the line leaves the first
    reach = math.dist((0, 0), (0.0, 0.15)) + math.dist((0.0, 0.15), (0.15, 0.3))
    p0 = here.points['P']
    exits = [outer_edge(p0, target, c, reach) for c in ((0.0, 0.0), (0.3, 0.0))]
    want = min(exits, key=lambda e: math.dist(p0, e))
    assert math.dist(edge.edge, want) < 1e-9
    assert edge.short_m == pytest.approx(math.dist(want, target), abs=1e-9)
    # an edge indeed: reachable there, not a micrometre further on
    assert solver.solve({'point:P': edge.edge}, commit=False).success
    u = ((target[0] - p0[0]) / math.dist(p0, target), (target[1] - p0[1]) / math.dist(p0, target))
    beyond = (edge.edge[0] + 1e-6 * u[0], edge.edge[1] + 1e-6 * u[1])
    assert not solver.solve({'point:P': beyond}, commit=False).success


def test_the_node_and_cli_refusal_names_the_point_and_the_edge_first():
    engine = Engine(Scene.from_dict(FIVE_BAR).mechanism, EngineSettings())
    r = engine.target({'P.x': 0.15, 'P.y': 2.0})
    assert not r.success
    assert r.reason.startswith('point P = (0.15, 2) m is out of reach: on the straight way there')
    assert 'reachable up to (0.15, 0.32' in r.reason  # the oracle's edge: y = 0.3296...
    assert 'does not close' in r.reason  # the solver's own reason follows
    ok = engine.target({'P.x': 0.16, 'P.y': 0.31})
    assert ok.success and 'out of reach' not in (ok.reason or '')


def test_a_coordinate_target_out_of_reach_names_the_coordinate_and_its_edge():
    """One coordinate known (the four-bar's P.x, 1 DOF) beyond the coupler curve: the refusal
    said only how far the loops missed closing. Its edge is the largest P.x of the circuit the
    mechanism is on (a Grashof crank-rocker: the crank turns fully in its mode), the oracle a
    dense sweep of the forward closed form."""
    from scenes import load

    mech = load('four_bar')
    engine = Engine(mech, EngineSettings())
    r = engine.target({'P.x': 10.0})
    assert not r.success
    assert r.reason.startswith('P.x = 10 m is out of reach: on the straight way there')
    fwd = Solver(mech, method='closed_form', branch='reference')
    crank = np.linspace(-math.pi, math.pi, 200001)
    xs = fwd.solve_batch({'crank': crank}).points['P'][:, 0]
    solver = Solver(mech, knowns=['P.x'])
    edge = reach_edge(solver, {'P.x': 10.0}, engine.last)
    assert edge is not None and edge.coordinate == 'P.x'
    assert edge.edge[0] == pytest.approx(float(np.max(xs)), abs=1e-7)
    assert edge.short_m == pytest.approx(10.0 - edge.edge[0], abs=1e-12)
    assert f'reachable up to P.x = {edge.edge[0]:.6g} m' in r.reason


@pytest.mark.parametrize('far', [1e20, 1e300])
def test_a_target_far_beyond_the_mechanism_gets_the_same_edge(far):
    """The bisection's 2^-40 of a 1e300 m line is wider than the mechanism: P.x = 1e300 was
    said reachable up to the current P.x (0.160 m) where the edge is 0.1707 m. Oracle: the
    dense sweep of the forward closed form, as above."""
    from scenes import load

    mech = load('four_bar')
    engine = Engine(mech, EngineSettings())
    fwd = Solver(mech, method='closed_form', branch='reference')
    crank = np.linspace(-math.pi, math.pi, 200001)
    top = float(np.max(fwd.solve_batch({'crank': crank}).points['P'][:, 0]))
    edge = reach_edge(Solver(mech, knowns=['P.x']), {'P.x': far}, engine.last)
    assert edge is not None and edge.edge[0] == pytest.approx(top, abs=1e-7)
    r = engine.target({'P.x': far})
    assert f'reachable up to P.x = {top:.6g} m' in r.reason, r.reason


@pytest.mark.parametrize('far', [1e308, -1.7e308])
def test_a_target_near_the_largest_double_is_refused_not_raised(far):
    """P.x = 1e308 overflowed the loop rows and scipy's least squares raised ('Residuals are
    not finite in the initial point') through the solve: a traceback, where any other value
    gets a refusal."""
    from scenes import load

    engine = Engine(load('four_bar'), EngineSettings())
    r = engine.target({'P.x': far})
    assert not r.success and 'is out of reach' in r.reason
    assert 'loop-closure equations overflow' in r.reason
