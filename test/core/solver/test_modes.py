"""Every assembly mode where Newton places the mechanism (issue 18): a multi-start search.

Oracle: the closed-form dyad plan's sign combinations, which are every mode exactly; the Newton
search must find the same regular modes (never one the closed form does not have), and where it
cannot be sure, say the list may be incomplete.
"""

from __future__ import annotations

import json
import math

import pytest
from scenes import load

from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.solver import Solver

CASES = [
    ('four_bar', {'crank': 0.5}),
    ('front_loader', {'Z1': 1.8, 'Z2': 1.9}),
    ('hart', {'crank': 0.4}),
    ('scott_russell', {'crank': 0.3}),
    ('quick_return', {'crank': 0.3}),
    ('excavator', {'Z1': 1.5, 'Z2': 2.0, 'Z3': 1.4}),
    ('peaucellier', {'crank': 0.3}),
]


def _same(a, b, scale):
    return max(math.dist(a.points[p], b.points[p]) for p in a.points) < 1e-9 * scale


@pytest.mark.parametrize('stem, command', CASES)
def test_newton_search_finds_the_closed_form_modes_and_says_it_searched(stem, command):
    mech = load(stem)
    scale = mech.length_scale
    exact = Solver(mech, method='closed_form').modes(command)
    assert exact.complete
    regular = [r for r in exact.results if r.margin > 1e-9]  # a mode at a toggle is singular
    found = Solver(mech, method='newton').modes(command)
    assert not found.complete and 'may be incomplete' in found.method
    for r in found.results:  # each closes the loops, and is one of the exact modes
        assert r.success and r.residual <= 1e-12, r.residual
        assert any(_same(r, e, scale) for e in exact.results), 'a mode the closed form lacks'
    for i, a in enumerate(found.results):  # distinct
        assert not any(_same(a, b, scale) for b in found.results[i + 1 :])
    missing = [e for e in regular if not any(_same(e, r, scale) for r in found.results)]
    # a search may miss a mode (that is why it says so): up to 8 modes it finds them all here;
    # of the excavator's 16 it finds 15 from 64 starts and 16 from 128 on this machine, and the
    # Newton paths may differ in the last bits on another CPU: allow a quarter missing there
    allowed = 0 if len(regular) <= 8 else len(regular) // 4
    assert len(missing) <= allowed, f'{len(missing)} of {len(regular)} regular modes not found'


def test_the_cli_says_whether_the_list_is_every_mode(capsys):
    assert cli_main(['solve', 'four_bar', '--set', 'crank=0.5', '--all-branches', '--json']) == 0
    modes = json.loads(capsys.readouterr().out)
    assert len(modes) == 2 and all(d['modes_complete'] is True for d in modes)
    argv = ['solve', 'four_bar', '--set', 'crank=0.5', '--all-branches', '--solver', 'newton']
    assert cli_main([*argv, '--json']) == 0
    modes = json.loads(capsys.readouterr().out)
    assert len(modes) == 2 and all(d['modes_complete'] is False for d in modes)
    assert cli_main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith('assembly modes: 2 found (Newton from 128 starts: may be incomplete)')


def test_a_toggle_is_warned_below_the_one_sign_threshold_in_one_wording():
    """reference_toggle_warnings (closed form) and reference_pose_warnings (hybrid) word a
    reference pose at a toggle alike (modes.toggle_warnings), below result.SIGN_MARGIN, the
    threshold below which a branch sign is not read as the assembly mode."""
    import re

    from scenes import four_bar

    from linkage_ros.core.model import Scene
    from linkage_ros.core.reference_warnings import reference_pose_warnings
    from linkage_ros.core.solver.modes import toggle_warnings
    from linkage_ros.core.solver.result import SIGN_MARGIN

    plan = Solver(four_bar(0.30, 0.10, 0.25, 0.20)).plan
    (step,) = plan.branch_steps
    got = toggle_warnings(plan, [0.5 * SIGN_MARGIN])
    assert toggle_warnings(plan, [2.0 * SIGN_MARGIN]) == []
    wording = (
        r'the reference pose is at the toggle of (.+) \(margin [0-9.e+-]+\): its assembly mode '
        r'there is not chosen by the drawing; draw the pose off the toggle to choose it'
    )
    (one,) = got
    assert re.fullmatch(wording, one).group(1) == step.describe(plan)
    # a four-bar drawn with coupler and rocker stretched out in line (0.15 + 0.15 = |A O4|):
    # the solver's own reading of its drawing warns in the same words
    flat = Scene.from_dict(
        {
            'name': 'flat',
            'points': {'O2': [0, 0], 'A': [0.1, 0], 'B': [0.25, 0], 'O4': [0.4, 0]},
            'links': {
                'ground': ['O2', 'O4'],
                'crank': ['O2', 'A'],
                'coupler': ['A', 'B'],
                'rocker': ['O4', 'B'],
            },
            'actuators': {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}},
        }
    ).mechanism
    (warned,) = reference_pose_warnings(Solver(flat))
    assert re.fullmatch(wording, warned)
