"""The `linkage` program itself: usage errors (exit 2, one line), --help, plug-in subcommands,
the installed console script, Ctrl-C and a standard output that cannot be written."""

import subprocess
import sys
from pathlib import Path

import pytest
from cli_helpers import loads, run

from linkage_ros.cli import parser as cli_parser

# ---- usage errors ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    'argv,needle',
    [
        (['solve', '{missing}', '--set', 'crank=1'], 'not found'),
        (['solve', '{four_bar}', '--set', 'crank'], 'NAME=VALUE'),
        (['solve', '{four_bar}', '--set', 'crank=abc'], "'abc' is not a number"),
        (['solve', '{four_bar}', '--set', 'crank=nan'], 'finite'),
        (['solve', '{four_bar}', '--set', 'cranky=1'], "'cranky' is not an actuator"),
        (['solve', '{four_bar}', '--target', 'nosuch=1'], "unknown name 'nosuch'"),
        (['solve', '{four_bar}', '--target-point', 'crank=1,2'], "'crank' is not a point"),
        (['solve', '{four_bar}', '--set', 'crank=0:1:3'], 'sweep'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--set', 'crank=2'], 'given twice'),
        (['solve', '{four_bar}'], 'nothing to solve'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--branch', 'sideways'], 'branch'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--branch', '++'], 'branching dyad'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--tol', '-1'], 'tolerance'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--tol', '1'], 'tolerance 1 is too loose'),
        (['solve', '{four_bar}', '--set', 'crank=1', '--solver', 'magic'], 'invalid choice'),
        (['sweep', '{four_bar}', '--set', 'crank=0:1:0'], 'COUNT must be >= 1'),
        (['sweep', '{four_bar}', '--set', 'crank=0:1:x'], 'not an integer'),
        (['check', '{bad_dof}'], 'degree(s) of freedom'),
        (['solve'], 'SCENE'),
        (['frobnicate'], 'invalid choice'),
    ],
)
def test_usage_errors_exit_2_with_one_line(capsys, scenes, tmp_path, argv, needle):
    names = dict(scenes, missing=str(tmp_path / 'nope.yaml'))
    rc, out, err = run(capsys, *[a.format(**names) for a in argv])
    assert rc == 2
    assert out == ''
    assert err.count('\n') == 1 and err.startswith('linkage') and 'error' in err
    assert needle in err
    assert 'Traceback' not in err


def test_help(capsys):
    rc, out, _ = run(capsys, '--help')
    assert rc == 0 and all(c in out for c in ('solve', 'sweep', 'check'))
    for sub, word in (('solve', '--target-point'), ('sweep', 'slowest'), ('check', 'Kutzbach')):
        rc, out, _ = run(capsys, sub, '--help')
        assert rc == 0 and word in out


# ---- plug-in subcommands -----------------------------------------------------------------------


def test_external_commands_register_when_importable(capsys, tmp_path, monkeypatch):
    (tmp_path / 'cli_plugin_ok.py').write_text(
        '"""Say hello."""\n'
        'def add_arguments(p):\n    p.add_argument("who")\n'
        'def run(args):\n    print("hello", args.who)\n    return 0\n'
    )
    (tmp_path / 'cli_plugin_broken.py').write_text('import no_such_dependency_xyz\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(
        cli_parser,
        'EXTERNAL_COMMANDS',
        {'hello': 'cli_plugin_ok', 'broken': 'cli_plugin_broken', 'absent': 'cli_plugin_absent'},
    )
    rc, out, _ = run(capsys, 'hello', 'world')
    assert rc == 0 and out == 'hello world\n'
    rc, out, _ = run(capsys, '--help')
    assert 'hello' in out and 'unavailable: broken' in out and 'absent' not in out
    rc, out, err = run(capsys, 'broken')
    assert rc == 2 and 'no_such_dependency_xyz' in err


# ---- the installed console script -------------------------------------------------------------


def test_console_script_is_installed(scenes):
    exe = Path(sys.executable).parent / 'linkage'
    assert exe.exists(), f'console script not installed next to {sys.executable}'
    proc = subprocess.run(
        [str(exe), 'solve', scenes['four_bar'], '--set', 'crank=0.5', '--json'],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0, proc.stderr
    assert loads(proc.stdout)['status'] == 'ok'


def test_ctrl_c_is_one_line_and_exit_130(capsys, monkeypatch):
    """Ctrl-C during a command (here inside the check) ends with the shell's SIGINT status and
    one line on stderr, not a traceback."""
    from linkage_ros.cli import check

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(check, 'check_report', interrupted)
    rc, out, err = run(capsys, 'check', 'four_bar')
    assert rc == 130
    assert err.strip() == 'linkage check: interrupted' and 'Traceback' not in err


@pytest.mark.skipif(not Path('/dev/full').exists(), reason='needs /dev/full')
@pytest.mark.parametrize(
    'argv', [['solve', 'four_bar', '--set', 'crank=1'], ['check', 'four_bar'], ['urdf', 'four_bar']]
)
def test_a_standard_output_that_cannot_be_written_is_one_error_line(argv):
    """stdout on a full disk (/dev/full): one line naming it and exit 2 (a usage error), not
    a traceback with exit 1 (which says 'solve refused')."""
    exe = Path(sys.executable).parent / 'linkage'
    with open('/dev/full', 'w') as full:
        proc = subprocess.run(
            [str(exe), *argv], stdout=full, stderr=subprocess.PIPE, text=True, timeout=60
        )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().endswith('cannot write standard output: No space left on device')
    assert 'Traceback' not in proc.stderr and proc.stderr.count('\n') == 1, proc.stderr


@pytest.mark.parametrize('value', ['nan', 'inf', '-1', 'soon'])
@pytest.mark.parametrize(
    'argv',
    [
        ['echo', '/nonexist', '--wait'],
        ['record', '/x', '-o', 'r', '--wait'],
        ['record', '/x', '-o', 'r', '--duration'],
        ['param', 'get', '/n', 'x', '--wait'],
    ],
)
def test_seconds_that_are_no_time_are_usage_errors(argv, value, capsys, tmp_path, monkeypatch):
    """`echo --wait nan` (or inf) waited forever and `param get --wait -1` said 'within -1 s'
    (an adversary): a wait or duration is a finite number of seconds, 0 or more."""
    from cli_helpers import run

    monkeypatch.chdir(tmp_path)
    rc, _, err = run(capsys, *argv, value)
    assert rc == 2, err
    assert f'argument {argv[-1]}: ' in err and value in err, err
    assert list(tmp_path.iterdir()) == []  # (record wrote nothing)


@pytest.mark.parametrize(
    ('node', 'why'),
    [
        ('/linkage_node/', "it ends with '/'"),
        ('//linkage_node', "must not contain repeated '/'"),
        ('/ünï', 'must not contain characters other than'),
    ],
)
def test_a_node_name_that_is_none_is_a_usage_error(node, why, capsys):
    """`linkage param get /linkage_node/ demo_rate` was rclpy's InvalidServiceNameException
    traceback, exit 1 (which says 'the node refused the value': an adversary)."""
    from cli_helpers import run

    rc, _, err = run(capsys, 'param', 'get', node, 'demo_rate', '--wait', '0')
    assert rc == 2, err
    assert f'NODE {node!r} is not a node name: ' in err and why in err, err


def test_grids_beyond_what_memory_holds_are_refused_before_any_work(capsys, tmp_path):
    """`range four_bar --point P --samples 100000000` took 12 GB in a minute and `sweep --set
    crank=0:1:1000000000 --csv` grew without end (an adversary): refused at once, saying the
    grid's size and the bound; a --json sweep of any size still streams."""
    from cli_helpers import run

    rc, _, err = run(capsys, 'range', 'four_bar', '--point', 'P', '--samples', 10**8)
    assert rc == 2 and '100,000,000 configurations, more than 4,000,000' in err, err
    rc, _, err = run(capsys, 'range', 'front_loader', '--point', 'D', '--samples', 2001)
    assert rc == 2 and '2001^2 = 4,004,001 configurations' in err, err
    csv = tmp_path / 'h.csv'
    rc, _, err = run(capsys, 'sweep', 'four_bar', '--set', 'crank=0:1:1000000000', '--csv', csv)
    assert rc == 2 and '1,000,000,000 grid points are more than 2,000,000' in err, err
    assert not csv.exists()


@pytest.mark.parametrize(
    'argv',
    [
        ['sweep', 'four_bar', '--set', 'crank=0:1:3', '--csv'],
        ['urdf', 'four_bar', '-o'],
        ['range', 'four_bar', '--point', 'P', '--plot'],
        ['bag', 'nobag', '--scene', 'four_bar', '--command-topic', '/cmd', '--out'],
        ['bag', 'nobag', '--scene', 'four_bar', '--command-topic', '/cmd', '--out-dir'],
    ],
)
def test_an_empty_output_name_is_a_usage_error(argv, capsys, tmp_path, monkeypatch):
    """`--csv ''` wrote no file and said nothing, `--out ''` 'exists already', `--out-dir ''`
    was the current folder (an adversary): an output needs a name."""
    from cli_helpers import run

    monkeypatch.chdir(tmp_path)
    rc, out, err = run(capsys, *argv, '')
    assert rc == 2 and f'argument {argv[-1]}' in err and 'got an empty one' in err, err
    assert list(tmp_path.iterdir()) == []
