"""The shared engine's protections for a live node (issue 19)."""

from __future__ import annotations

import itertools

from scenes import load

from linkage_ros.engine import SOLVER_CACHE, Engine, EngineSettings
from linkage_ros.params import TARGET_COMPILE_RATE, make_config


def test_a_flood_of_new_target_name_sets_is_bounded_by_the_compile_budget():
    """Each new set of target names compiles a solver (~3 ms on the excavator): a client
    flooding ever new sets used to thrash the cache and starve ~/command. The node's engine
    compiles at most compile_rate new sets per second (after a burst of the cache's size) and
    refuses the rest with the reason; sets already compiled are answered whatever the rate."""
    mech = load('excavator')
    now = [100.0]
    e = Engine(
        mech,
        EngineSettings('auto', 1e-12, 50, 'continuous', compile_rate=5.0),
        clock=lambda: now[0],
    )
    names = [n for n in list(mech.joint_names) + list(mech.links) if n != mech.ground]
    sets = [list(c) for c in itertools.islice(itertools.combinations(names, 3), 60)]
    got = [e.solver_for(s) for s in sets[: SOLVER_CACHE + 3]]
    busy = [g for g in got if isinstance(g, str) and g.startswith('too many new sets')]
    assert len(busy) == 3 and 'at most 5 new ones per second' in busy[0]
    first = e.solver_for(sets[0])  # compiled before: answered whatever the budget
    assert not (isinstance(first, str) and first.startswith('too many'))
    now[0] += 1.0  # one second: five more
    more = [e.solver_for(s) for s in sets[SOLVER_CACHE + 3 : SOLVER_CACHE + 9]]
    assert sum(isinstance(g, str) and g.startswith('too many') for g in more) == 1
    # offline (the bag tool): no budget, every set is compiled
    free = Engine(mech, EngineSettings('auto', 1e-12, 50, 'continuous'))
    assert not any(
        isinstance(g, str) and 'too many' in g for g in (free.solver_for(s) for s in sets)
    )


def test_the_node_sets_the_compile_budget():
    assert make_config({}).engine_settings().compile_rate == TARGET_COMPILE_RATE
