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

from linkage_ros.cli import main as cli_main
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
