"""The ``branch`` setting names an assembly mode of the forward plan (TOPICS: "one sign per
branching dyad ... of the forward plan"), and a target is answered in it.

A target's solver was built with the setting's signs applied to its own (inverse) plan, whose
dyads are not the forward plan's: under ``branch: '-'`` the four-bar's target rocker = 1.9 came
back in the open pose (mode +) with the status saying '-', and the next command flipped the
mechanism back. ``--all-branches`` of a target labelled its answers with the inverse plan's signs
too. Oracle: the forward closed form in the labelled mode at the answer's crank angle places
the same configuration (and B's sign is the four-bar's mode: the coupler-rocker angle)."""

from __future__ import annotations

import math

import pytest
from scenes import load

from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.solver import Solver
from linkage_ros.engine import Engine, EngineSettings


def _forward_in(mech, branch, crank):
    return Solver(mech, method='closed_form', branch=branch).solve({'crank': crank})


@pytest.mark.parametrize('branch', ['-', '+', 'reference'])
def test_a_target_is_answered_in_the_mode_the_setting_names(branch):
    mech = load('four_bar')
    e = Engine(mech, EngineSettings(branch=branch))
    mode = '+' if branch == 'reference' else branch  # the drawing is in mode +
    for target, value in (('rocker', 1.9), ('B', -1.2), ('B', 1.2)):
        r = e.target({target: value})
        if not r.success:  # then only the other mode reaches it
            assert f'keeps the mechanism in mode {mode}' in r.reason, r.reason
            other = '-' if mode == '+' else '+'
            assert f'reachable only in assembly mode {other}' in r.reason
            continue
        assert r.branch == mode
        fwd = _forward_in(mech, mode, r.inputs['crank'])
        for p, xy in fwd.points.items():
            assert math.dist(xy, r.points[p]) <= 1e-12 * mech.length_scale, (target, p)
        # the next command continues in that mode (it flipped back)
        c = e.command({'crank': r.inputs['crank']})
        assert c.success and c.branch == mode
    # the mode is the sign of B here: each target reaches exactly one of the two
    assert e.target({'B': -1.2 if mode == '-' else 1.2}).success


def test_the_modes_of_a_target_are_the_mechanisms(capsys):
    mech = load('four_bar')
    found = Solver(mech, knowns=['B']).modes({'B': -1.2})
    assert len(found.results) == 2 and found.complete
    for r in found.results:
        assert r.branch == '-'  # it said '+' and '-' (the inverse plan's signs)
        fwd = _forward_in(mech, r.branch, r.inputs['crank'])
        assert math.dist(fwd.points['B'], r.points['B']) <= 1e-12 * mech.length_scale
    assert cli_main(['solve', 'four_bar', '--target', 'B=-1.2', '--all-branches']) == 0
    out = capsys.readouterr().out
    assert '(as drawn)' not in out and '--- solution 1 of 2 (branch -)' in out
    assert cli_main(['solve', 'four_bar', '--target', 'B=-1.2', '--branch', '-']) == 0
    assert 'branch     -' in capsys.readouterr().out
    assert cli_main(['solve', 'four_bar', '--target', 'rocker=1.9', '--branch', '-']) == 1
    assert "the branch setting '-' keeps the mechanism in mode -" in capsys.readouterr().out


def _gear_checks(r, knee_side):
    """An answer of the landing gear closes every loop at the drawing's lengths, with its
    brace's knee on ``knee_side`` of the line U -> S (independent of the solver: the points
    it published, the drawing's distances)."""
    from scenes import LANDING_GEAR

    P = {k: complex(*v) for k, v in LANDING_GEAR['points'].items()}
    p = {k: complex(*v) for k, v in r.points.items()}
    for a, b in (('U', 'K'), ('K', 'S'), ('O', 'S'), ('O', 'R'), ('S', 'R')):
        assert abs(abs(p[a] - p[b]) - abs(P[a] - P[b])) < 1e-9, (a, b)
    u, k = p['S'] - p['U'], p['K'] - p['U']
    assert (1 if (u.conjugate() * k).imag > 0 else -1) == knee_side


def test_a_hybrid_target_continues_from_a_state_over_centre():
    """A landing gear's strut-angle target is placed by a hybrid plan (the brace's knee by a
    dyad, the cylinder by Newton). That dyad was always placed in the drawing's sign: under
    branch '++' a trajectory of two strut targets was refused at its second point ('the mode
    changes from ++ to +-') though each alone is answered in ++, and with the knee moved over
    centre (a target in another mode, asked for) the next plain target snapped it back without
    a word (an outside integrator). Oracle: each answer's loops closed at the drawing's lengths
    and its knee's side, read off the published points."""
    from scenes import LANDING_GEAR

    from linkage_ros.core.model import Scene
    from linkage_ros.trajectory import solve_trajectory

    mech = Scene.from_dict(LANDING_GEAR).mechanism
    held = Engine(mech, EngineSettings(branch='++'))
    start = held.command({'stroke': 0.0})
    assert start.success and start.branch == '++'
    u = complex(*start.points['S']) - complex(*start.points['U'])
    k = complex(*start.points['K']) - complex(*start.points['U'])
    side = 1 if (u.conjugate() * k).imag > 0 else -1
    theta = start.links['strut']
    targets = [[theta + 0.01], [theta + 0.05]]
    answer = solve_trajectory(held, ['link:strut'], targets, [], None)
    assert answer.success, answer.reason
    for (want,), r in zip(targets, answer.results):
        assert abs(r.links['strut'] - want) < 1e-12 and r.branch == '++'
        _gear_checks(r, side)
    # the default setting: the knee moved over centre on request, then a plain target
    free = Engine(mech, EngineSettings())
    assert free.command({'stroke': 0.0}).branch == '+-'
    over = free.solve_target(
        free.solver_for(['link:upper_brace']),
        {'link:upper_brace': start.links['upper_brace']},
        allow_mode_change=True,
    )
    assert over.success and over.branch == '++', over.reason
    after = free.target({'link:strut': theta + 0.05})
    assert after.success and after.branch == '++', (after.branch, after.reason)
    _gear_checks(after, side)
