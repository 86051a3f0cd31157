"""Option values argparse would misread: a --branch of signs alone starting with '-' (read as
another option, and '--' dropped even in '--branch=--'), and a single-valued option given
twice (the first silently dropped: two --target-topic options read one topic). A new user's
first hour."""

from __future__ import annotations

import pytest
from cli_helpers import run

SET = ['--set', 'Z1=1.5', '--set', 'Z2=1.6', '--set', 'Z3=1.3']


@pytest.mark.parametrize('argv', [['--branch', '-+'], ['--branch=-+'], ['--branch', '--'],
                                  ['--branch=--'], ['--branch', '-']])  # fmt: skip
def test_a_branch_of_signs_starting_with_minus_reaches_the_solver(capsys, argv):
    signs = argv[-1].removeprefix('--branch=')
    rc, _, err = run(capsys, 'solve', 'excavator', *SET, *argv)
    # the excavator has 4 branching dyads: the signs arrive as given, and are refused so
    assert rc == 2
    assert f"branch '{signs}' has {len(signs)} sign(s) but this solve has 4" in err, err


def test_the_drawings_mode_given_with_a_leading_minus_is_answered_in_it(capsys):
    rc, out, err = run(capsys, 'solve', 'four_bar', '--set', 'crank=0.3', '--branch', '-')
    assert rc == 0, err
    assert '\nbranch     -' in out


def test_a_single_valued_bag_option_given_twice_is_refused(capsys, tmp_path):
    rc, _, err = run(capsys, 'bag', str(tmp_path), '--scene', 'four_bar', '--command-topic',
                     '/c', '--target-topic', '/a', '--target-topic', '/b', '--out',
                     str(tmp_path / 'x.csv'))  # fmt: skip
    assert rc == 2
    assert '--target-topic given more than once (it takes one value)' in err


@pytest.mark.parametrize(
    'argv',
    [
        ['solve', 'four_bar', '--set', 'crank=1', '--branch', '+', '--branch', '-'],
        ['solve', 'four_bar', '--set', 'crank=1', '--tol', '1e-9', '--tol', '1e-6'],
        ['range', 'four_bar', '--samples', '50', '--samples', '60'],
    ],
)
def test_any_single_valued_option_given_twice_is_refused(capsys, argv):
    """Every option that takes one value (--scene, --branch, --solver, --tol, --out-dir ...)
    kept its last value silently given twice (an adversary: two --out-dir wrote the second
    only); one rule for every command's parser now."""
    rc, out, err = run(capsys, *argv)
    assert rc == 2 and out == ''
    assert 'given more than once (it takes one value)' in err
