"""Assembly modes of a scene Newton places: found once each, named by the sign of the loop
Jacobian's determinant ('J+' / 'J-'), selectable by that name, and kept by targets as the
dyad signs are (issue 26, items 5-7).

The oracle for the 3-RPR's forward kinematics is independent of the solver: for each platform
angle phi the first two legs put P1 on two circles (two candidates), and a root of the third
leg's length error over phi is an assembly mode; a fine scan counts them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from linkage_ros.core.errors import PlanError
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings

GROUND = {'G1': (0.0, 0.0), 'G2': (1.0, 0.0), 'G3': (0.5, 0.9)}
PLATFORM = {'P1': (0.35, 0.25), 'P2': (0.65, 0.25), 'P3': (0.5, 0.51)}
LEGS = {'L1': 0.5, 'L2': 0.55, 'L3': 0.45}


def three_rpr():
    return Scene.from_dict(
        {
            'name': 'three_rpr',
            'points': {k: list(v) for k, v in {**GROUND, **PLATFORM}.items()},
            'links': {'ground': list(GROUND), 'platform': list(PLATFORM)},
            'cylinders': {f'L{i}': {'from': f'G{i}', 'to': f'P{i}'} for i in (1, 2, 3)},
        }
    ).mechanism


def fk_oracle(legs: dict[str, float], n: int = 200_000) -> list[np.ndarray]:
    """Every forward-kinematics solution (P1, P2, P3) of the 3-RPR, by the scan of the module
    docstring (each sign change of the third leg's error, refined by bisection)."""
    g1, g2, g3 = (np.array(GROUND[k]) for k in ('G1', 'G2', 'G3'))
    p1, p2, p3 = (np.array(PLATFORM[k]) for k in ('P1', 'P2', 'P3'))
    l1, l2, l3 = legs['L1'], legs['L2'], legs['L3']

    def rot(phi):
        c, s = np.cos(phi), np.sin(phi)
        return np.array([[c, -s], [s, c]])

    def candidates(phi, side):
        e12 = rot(phi) @ (p2 - p1)  # P2 = P1 + e12
        c2 = g2 - e12  # P1 on circle (g2 - e12, l2) and circle (g1, l1)
        d = np.linalg.norm(c2 - g1)
        a = (d * d + l1 * l1 - l2 * l2) / (2 * d)
        h2 = l1 * l1 - a * a
        if h2 < 0:
            return None
        u = (c2 - g1) / d
        P1 = g1 + a * u + side * math.sqrt(h2) * np.array([-u[1], u[0]])
        return P1, P1 + e12, P1 + rot(phi) @ (p3 - p1)

    def err(phi, side):
        got = candidates(phi, side)
        return None if got is None else np.linalg.norm(got[2] - g3) - l3

    out = []
    phis = np.linspace(-math.pi, math.pi, n + 1)
    for side in (1.0, -1.0):
        prev = None
        for a, b in zip(phis[:-1], phis[1:]):
            fa, fb = err(a, side) if prev is None else prev, err(b, side)
            prev = fb
            if fa is None or fb is None or fa * fb > 0:
                continue
            for _ in range(60):
                m = 0.5 * (a + b)
                fm = err(m, side)
                if fm is None:
                    break
                a, b, fa = (a, m, fa) if fa * fm <= 0 else (m, b, fm)
            out.append(np.concatenate(candidates(0.5 * (a + b), side)))
    return out


def points_of(result) -> np.ndarray:
    return np.concatenate([np.array(result.points[p]) for p in ('P1', 'P2', 'P3')])


def test_three_rpr_lists_each_mode_once_with_a_label():
    mech = three_rpr()
    truth = fk_oracle(LEGS)
    assert len(truth) == 2
    modes = Solver(mech).modes(LEGS)
    assert len(modes.results) == len(truth)
    for exact in truth:  # every true mode listed, to the oracle's bisection
        assert min(np.max(np.abs(points_of(r) - exact)) for r in modes.results) < 1e-9
    labels = sorted(r.branch for r in modes.results)
    assert labels == ['J+', 'J-']


@pytest.mark.parametrize('label', ['J+', 'J-'])
def test_a_newton_mode_is_selected_by_its_label(label):
    mech = three_rpr()
    listed = {r.branch: r for r in Solver(mech).modes(LEGS).results}
    got = Solver(mech, branch=label).solve(LEGS)
    assert got.success and got.branch == label
    assert np.max(np.abs(points_of(got) - points_of(listed[label]))) < 1e-9
    # independent check of the answer: every leg has its length, the platform is rigid
    for i in (1, 2, 3):
        assert abs(math.dist(got.points[f'G{i}'], got.points[f'P{i}']) - LEGS[f'L{i}']) < 1e-12
    for a, b in (('P1', 'P2'), ('P2', 'P3'), ('P1', 'P3')):
        assert (
            abs(math.dist(got.points[a], got.points[b]) - math.dist(PLATFORM[a], PLATFORM[b]))
            < 1e-12
        )


def test_labels_are_refused_where_they_do_not_name_a_mode():
    with pytest.raises(PlanError, match='branching dyad'):
        Solver(three_rpr(), branch='+')
    four_bar = Scene.from_dict(
        {'four_bar': {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}}
    )
    with pytest.raises(PlanError, match="J\\+' names an assembly mode of a scene Newton places"):
        Solver(four_bar.mechanism, branch='J+')


def test_a_target_keeps_the_jacobian_mode_of_a_newton_scene():
    mech = three_rpr()
    engine = Engine(mech, EngineSettings())
    here = engine.command(LEGS)
    assert here.success and here.branch in ('J+', 'J-')
    other = next(r for r in Solver(mech).modes(LEGS).results if r.branch != here.branch)
    # the other mode's platform pose as a target: every answer of it is in the other mode
    target = {
        'P1.x': other.points['P1'][0],
        'P1.y': other.points['P1'][1],
        'platform': other.links['platform'],
    }
    refused = engine.target(target)
    assert not refused.success
    assert f'reachable only in assembly mode {other.branch}' in refused.reason
    assert f'the mechanism is in mode {here.branch}' in refused.reason
    moved = engine.target(target, allow_mode_change=True)
    assert moved.success and moved.mode_change == f'{here.branch} -> {other.branch}'
    assert moved.branch == other.branch
    assert np.max(np.abs(points_of(moved) - points_of(other))) < 1e-9
    # later commands continue in the new mode
    again = engine.command(LEGS)
    assert again.success and again.branch == other.branch


def test_a_target_answer_names_the_forward_mode_not_the_inverse_plans_signs():
    mech = Scene.from_dict(
        {'four_bar': {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}}
    ).mechanism
    engine = Engine(mech, EngineSettings())
    before = engine.command({'crank': 0.5})
    assert before.success
    forward = Solver(mech)
    # the rocker angle of the other assembly mode: the inverse plan (rocker -> B, then an RRR
    # dyad for A) has a sign of its own, which is not the forward dyad's
    other = Solver(mech, branch='-' if before.branch == '+' else '+').solve({'crank': 0.5})
    moved = engine.target({'rocker': other.links['rocker']}, allow_mode_change=True)
    assert moved.success, moved.reason
    assert moved.mode_change  # the target is the other mode's configuration
    mode = forward.mode_of(moved)
    assert mode is not None
    assert moved.branch == ''.join('+' if s > 0 else '-' for s in mode[0])
    assert (
        moved.mode_change == f'{before.branch} -> {moved.branch} (another circuit)'
        and moved.branch != before.branch
    )
