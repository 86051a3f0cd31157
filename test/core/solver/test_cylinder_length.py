"""A cylinder's value is its pin-to-pin length: more than 0 whatever its limits say.

A cylinder with no `min` (SCENES.md: "min must be > 0" where given) took a command of -0.3 m
and answered OK with the barrel turned round (its direction from -> to reversed by pi) and the
pins 0.3 m apart; the command line refused it as "reachable only on the other loop". Every
path refuses it now, naming the length: the one-command closed form (its lean path and the
general one), the batch and the engine.

Oracle: the boom-lift's geometry. Pins P = (0.4, -0.1) on the ground and Q on the boom at
|OQ| from the pivot O: the cylinder length l puts Q where |Q - P| = l, so l spans
[|OQ| - |OP|, |OQ| + |OP|] and every length outside it, or at most 0, is refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings

LIFT = {
    'points': {'O': [0.0, 0.0], 'P': [0.4, -0.1], 'Q': [0.6, 0.25]},
    'links': {'ground': ['O', 'P'], 'boom': ['O', 'Q']},
    'cylinders': {'lift': {'from': 'P', 'to': 'Q'}},
}
OP, OQ = math.hypot(0.4, -0.1), math.hypot(0.6, 0.25)
NOT_A_LENGTH = "is not a length: a cylinder's pin-to-pin length is more than 0"


@pytest.fixture(scope='module')
def mech():
    return Scene.from_dict(LIFT).mechanism


@pytest.mark.parametrize('length', [-0.3, -1e-12, 0.0, -0.0, -math.inf])
@pytest.mark.parametrize('method', ['closed_form', 'newton'])
def test_a_length_of_0_or_less_is_refused_naming_the_length(mech, length, method):
    r = Solver(mech, method=method).solve({'lift': length})
    assert not r.success
    if math.isfinite(length):
        assert r.reason == f'lift = {length:.9g} m {NOT_A_LENGTH}'


def test_a_length_within_reach_is_answered_at_that_length(mech):
    for length in (OQ - OP + 1e-3, 0.5, OQ + OP - 1e-3):
        r = Solver(mech).solve({'lift': length})
        assert r.success, r.reason
        p, q = np.array(r.points['P']), np.array(r.points['Q'])
        assert np.linalg.norm(q - p) == pytest.approx(length, abs=1e-12)


def test_the_batch_refuses_the_same_rows(mech):
    lengths = np.array([-0.3, 0.0, 0.3, 0.5, -2.0])
    b = Solver(mech).solve_batch({'lift': lengths})
    assert b.ok.tolist() == [False, False, True, True, False]
    for i in (0, 1, 4):
        assert b.reason[i] == f'lift = {lengths[i]:.9g} m {NOT_A_LENGTH}'


def test_the_engine_refuses_it_and_keeps_its_state(mech):
    engine = Engine(mech, EngineSettings())
    before = dict(engine.last.inputs)
    r = engine.command({'lift': -0.3})
    assert not r.success and NOT_A_LENGTH in r.reason
    assert engine.last.inputs == before


def test_a_length_near_zero_the_geometry_allows_is_answered():
    """A boom O4-A (1 m) about O4 = (1, 0) and a cylinder from O2 = (0, 0) to A, no limits: its
    length runs from 0 (A on O2) to 2 m. The scan of a cylinder without a min started at 1e-6
    of the length scale, so 1e-6 m was refused as "reachable only on the other loop" while
    2e-6 m was answered (an outside adversary). Oracle: |A - O2| at the length."""
    data = {
        'points': {'O2': [0.0, 0.0], 'O4': [1.0, 0.0], 'A': [1.0, 1.0]},
        'links': {'ground': ['O2', 'O4'], 'boom': ['O4', 'A']},
        'cylinders': {'Z': {'from': 'O2', 'to': 'A'}},
    }
    engine = Engine(Scene.from_dict(data).mechanism, EngineSettings())
    for length in (1.0, 1e-3, 2e-6, 1e-6, 1e-9):
        r = engine.command({'Z': length})
        assert r.success, (length, r.reason)
        assert math.hypot(*r.points['A']) == pytest.approx(length, rel=1e-6)
