"""A target out of reach is refused in bounded work: it runs on the node's command thread, and
each such refusal held ~/command for 1.7-5.6 s (an outside adversary: three unreachable loader
targets delayed a command by 13 s).

Where the time went, and what is measured here instead of time (a timed unit test would be
noise on a shared machine):
* the 16 in-mode restarts (Newton walks from elsewhere in the mode) ran for a target refused as
  out of reach, which no restart places: they do not run now (the rule the multi-start search
  already followed, mode_rule._out_of_reach);
* every failed walk of the target's search measured its nearest configuration's miss (a
  least-squares search, ~0.1 s on the excavator) for a reason nobody read: only the refusal
  the client gets measures it now (Effort.UNEXPLAINED);
* the reach edge bisected 40 times, each probe a walk from the current configuration halving
  its step ten times past the fold: it now marches from the last value reached, each probe
  one direct Newton solve (Effort.DIRECT), and finds the same edge.

Oracles: the loader's and the excavator's reach edges as the 40-step bisection of full walks
found them before (read off the refusals, 6 significant digits); the probe at the edge solves
and one a step beyond does not (the solver's full walk, not the march's probe)."""

from __future__ import annotations

import pytest
from scenes import load

from linkage_ros.core.newton import system as newton_system
from linkage_ros.core.solver import Effort, Solver, mode_rule
from linkage_ros.engine import Engine, EngineSettings


@pytest.fixture
def counted(monkeypatch):
    """Counts of the least-squares miss searches, the restarts and each Effort's solves."""
    counts = {'least_miss': 0, 'restarts': 0, Effort.FULL: 0, Effort.UNEXPLAINED: 0}
    counts[Effort.DIRECT] = 0
    least_miss = newton_system.LoopSystem.least_miss
    multi_start = mode_rule.ModeKeeper._multi_start
    solve = Solver.solve

    def count_least_miss(self, *a, **k):
        counts['least_miss'] += 1
        return least_miss(self, *a, **k)

    def count_restarts(self, *a, **k):
        counts['restarts'] += 1
        return multi_start(self, *a, **k)

    def count_solve(self, values, commit=True, effort=Effort.FULL):
        counts[effort] += 1
        return solve(self, values, commit, effort)

    monkeypatch.setattr(newton_system.LoopSystem, 'least_miss', count_least_miss)
    monkeypatch.setattr(mode_rule.ModeKeeper, '_multi_start', count_restarts)
    monkeypatch.setattr(Solver, 'solve', count_solve)
    return counts


@pytest.mark.parametrize(
    ('scene', 'target', 'edge'),
    [
        ('front_loader', {'D.x': 10.0, 'bin': 2.3}, 'up to D.x = 2.84937 m'),
        ('excavator', {'K.x': 0.7, 'bucket': 0.6, 'Z1': 1.5}, 'up to K.x = 2.2739 m'),
    ],
)
def test_an_unreachable_target_is_refused_in_bounded_work(counted, scene, target, edge):
    engine = Engine(load(scene), EngineSettings())
    before = dict(engine.last.inputs)
    for k in list(counted):
        counted[k] = 0
    r = engine.target(target)
    assert not r.success
    name = next(iter(target))
    others = ', '.join(list(target)[1:])
    assert r.reason.startswith(
        f'{name} = {target[name]:g} m with {others} as given is out of reach'
    )
    assert edge in r.reason, r.reason
    assert 'nearest configuration misses closing by' in r.reason  # the one measured refusal
    assert counted['least_miss'] == 1
    assert counted['restarts'] == 0
    # the search's own solves: a few full-walk alternatives, the march's direct probes
    assert counted[Effort.FULL] <= 2
    assert counted[Effort.UNEXPLAINED] <= 8
    assert 10 <= counted[Effort.DIRECT] <= 200
    assert engine.last.inputs == before  # a refusal changes nothing


def test_the_marchs_edge_is_where_full_walks_stop():
    """The loader's D.x target with its bin held where it is: the march's edge (the last value
    its probes reached) is reached by a full continuation walk from the drawing, and a step of
    1e-4 of the way beyond it is not."""
    from linkage_ros.core.solver.reach import reach_edge

    mech = load('front_loader')
    engine = Engine(mech, EngineSettings())
    here = engine.last
    solver = Solver(mech, knowns=['D.x', 'bin'])
    solver.adopt(here)
    bin_now = here.links['bin']
    edge = reach_edge(solver, {'D.x': 10.0, 'bin': bin_now}, here)
    assert edge is not None and edge.coordinate == 'D.x'
    at = edge.edge[0]
    fresh = Solver(mech, knowns=['D.x', 'bin'])
    fresh.adopt(here)
    assert fresh.solve({'D.x': at, 'bin': bin_now}, commit=False).success
    way = 10.0 - here.points['D'][0]
    fresh.adopt(here)
    assert not fresh.solve({'D.x': at + 1e-4 * way, 'bin': bin_now}, commit=False).success


def test_an_angle_out_of_reach_is_named_beside_the_point_that_does_not_move():
    """The loader's bin hinge kept at its x and the bin turned to 9 rad: the bin angle is what
    is out of reach. The refusal had said "D.x = 2.2 m is out of reach ... reachable up to
    D.x = 2.2 m, 7.99e-15 m short", naming only the coordinate that does not move."""
    engine = Engine(load('front_loader'), EngineSettings())
    x = engine.last.points['D'][0]
    r = engine.target({'D.x': x, 'bin': 9.0})
    assert not r.success
    assert r.reason.startswith(f'D.x = {x:.6g} m with bin as given is out of reach'), r.reason
    assert 'every known moved together, it is reachable ' in r.reason
