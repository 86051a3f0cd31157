"""Compiling a plan looks at each body a bounded number of times: a scene of n independent
four-bars compiles in work linear in n (issue 27's big scenes: `linkage check` builds one
Solver of the whole mechanism). Counted, not timed: the bodies the search examines."""

from __future__ import annotations

import tempfile
from pathlib import Path

import yaml

from linkage_ros.bench.scaling import four_bars_scene
from linkage_ros.core.disjoint import DisjointSets
from linkage_ros.core.model import Scene
from linkage_ros.core.plan.compile import Plan
from linkage_ros.core.solver import Solver


def _four_bars(n: int):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / 'scene.yaml'
        path.write_text(yaml.safe_dump(four_bars_scene(n)))
        return Scene.from_yaml(path).mechanism


def _calls(n: int, owner: type, method: str, monkeypatch) -> int:
    """How many times one whole-scene Solver's build of ``n`` four-bars calls
    ``owner.method``."""
    mech = _four_bars(n)
    calls = 0
    original = getattr(owner, method)

    def counted(self, *args):
        nonlocal calls
        calls += 1
        return original(self, *args)

    monkeypatch.setattr(owner, method, counted)
    Solver(mech, branch='reference')
    monkeypatch.undo()
    return calls


def test_a_plan_of_n_four_bars_examines_its_bodies_a_linear_number_of_times(monkeypatch):
    small = _calls(10, Plan, '_two_distinct', monkeypatch)
    large = _calls(80, Plan, '_two_distinct', monkeypatch)
    assert small > 0
    # linear: 8x the four-bars, about 8x the work (the search before looked at every body
    # after each step: 64x)
    assert large <= 10 * small, (small, large)


def test_grouping_the_links_of_n_four_bars_is_linear(monkeypatch):
    """DisjointSets.find calls (grouping links into bodies: the search before looked at every
    known's edge for every body, n * n)."""
    small = _calls(10, DisjointSets, 'find', monkeypatch)
    large = _calls(80, DisjointSets, 'find', monkeypatch)
    assert small > 0
    assert large <= 10 * small, (small, large)


def test_a_big_scene_builds_no_dense_jacobian_template():
    """The whole-scene check system of 200 four-bars (a 1800 x 1800 J) is read for its pattern
    only: its template stays sparse (3.2M dense floats would be quadratic in the links)."""
    solver = Solver(_four_bars(200))
    template = solver.compiled.check_system.tables.template
    assert template.m * template.n == 1800 * 1800
    assert 'raw' not in vars(template) and 'scaled' not in vars(template)
