"""Bad arguments get a clear error naming what was wrong, never a raw traceback from deep
inside: the analysis functions (ValueError naming the argument), a solver's knowns and branch
signs (PlanError), the node's settings (ConfigError); messages quote at most a bounded part of
what they were given; a huge CLI sweep starts its output at once instead of building a list
first.
"""

import math
import sys

import numpy as np
import pytest
import scenes

from linkage_ros.cli import common as cli_common
from linkage_ros.cli.parser import main as cli_main
from linkage_ros.core.analysis import (
    fourbar_input_intervals,
    fourbar_input_range,
    fourbar_output_intervals,
    fourbar_output_range,
    fourbar_toggle_angles,
    transmission_angle,
)
from linkage_ros.core.model import Scene
from linkage_ros.core.solver import Solver

# ---- 1. analysis argument checks ------------------------------------------------------------


RANGE_FUNCS = [
    fourbar_input_range,
    fourbar_output_range,
    fourbar_input_intervals,
    fourbar_output_intervals,
    fourbar_toggle_angles,
]


@pytest.mark.parametrize('func', RANGE_FUNCS)
@pytest.mark.parametrize('pos', range(4))
@pytest.mark.parametrize('bad', [math.nan, math.inf, -math.inf, -0.3, 0.0, None, 'x'])
def test_range_functions_refuse_bad_lengths(func, pos, bad):
    args = [0.3, 0.1, 0.25, 0.2]
    args[pos] = bad
    with pytest.raises(ValueError, match=f'l{pos + 1} must be'):
        func(*args)


@pytest.mark.parametrize('scale', [1e300, 2.0**1021, 1e-300])
def test_range_functions_are_scale_invariant_for_huge_and_tiny_lengths(scale):
    for lengths in [(0.3, 0.1, 0.25, 0.2), (0.5, 0.4, 0.25, 0.3), (4.0, 3.0, 1.5, 4.5)]:
        big = [v * scale for v in lengths]
        for func in RANGE_FUNCS:
            want, got = func(*lengths), func(*big)
            assert (
                np.allclose(np.asarray(got, float), np.asarray(want, float), rtol=1e-12, atol=1e-12)
                if want is not None
                else got is None
            )


def test_toggle_angles_of_equal_huge_lengths():
    assert fourbar_toggle_angles(1e308, 1e308, 1e308, 1e308) == fourbar_toggle_angles(1, 1, 1, 1)


def test_unassemblable_message_shows_lengths_as_given():
    with pytest.raises(ValueError, match=r'sides 1e\+308, 1e\+300, 1e\+300, 1e\+300'):
        fourbar_input_range(1e308, 1e300, 1e300, 1e300)
    with pytest.raises(ValueError, match=r'sides 10.0, 1.0, 1.0, 1.0'):
        fourbar_output_range(10, 1, 1, 1)


def test_transmission_angle_with_huge_lengths():
    want = transmission_angle(3, 1, 2.5, 2, 1.0)
    assert transmission_angle(3e200, 1e200, 2.5e200, 2e200, 1.0) == want
    assert transmission_angle(3e300, 1e300, 2.5e300, 2e300, 1.0) == want
    both = transmission_angle([3, 3e300], [1, 1e300], [2.5, 2.5e300], [2, 2e300], 1.0)
    assert np.all(both == want)


@pytest.mark.parametrize(
    'pos,bad',
    [
        (4, math.nan),
        (4, None),
        (4, [1.0, None]),
        (4, math.inf),
        (4, 'x'),
        (0, math.nan),
        (1, -1.0),
        (2, [1.0, math.inf]),
        (3, None),
        (2, 0.0),
    ],
)
def test_transmission_angle_refuses_bad_arguments(pos, bad):
    args = [3, 1, 2.5, 2, 1.0]
    args[pos] = bad
    name = ['l1', 'l2', 'l3', 'l4', 'theta2'][pos]
    with pytest.raises(ValueError, match=f'{name} must be'):
        transmission_angle(*args)


# ---- 2. huge sweeps start at once -----------------------------------------------------------


def test_sweep_range_values_are_lazy():
    name, values, readings = cli_common.parse_known('--set', 'crank=0:1:1000000000001', True)
    assert name == 'crank' and all(r.unit is None for r in readings)
    assert len(values) == 10**12 + 1
    assert values[0] == 0.0 and values[-1] == 1.0 and values[1] == 1e-12
    assert list(cli_common.parse_known('--set', 'crank=0:3:7', True)[1]) == [
        0.0,
        0.5,
        1.0,
        1.5,
        2.0,
        2.5,
        3.0,
    ]
    _, pts, _ = cli_common.parse_known('--target-point', 'P=0,0:1,2:3', True)
    assert list(pts) == [(0.0, 0.0), (0.5, 1.0), (1.0, 2.0)]


class _Stop(Exception):
    pass


class _FewLines:
    """stdout that stops the sweep after a few lines."""

    def __init__(self, limit):
        self.lines, self.limit = [], limit

    def write(self, text):
        self.lines.append(text)
        if sum(t.count('\n') for t in self.lines) >= self.limit:
            raise _Stop

    def flush(self):
        pass


def test_huge_sweep_starts_printing_at_once(monkeypatch):
    out = _FewLines(4)
    monkeypatch.setattr(sys, 'stdout', out)
    with pytest.raises(_Stop):
        cli_main(['sweep', 'four_bar', '--set', 'crank=0:1:1000000000'])
    text = ''.join(out.lines).splitlines()
    assert text[0].startswith('#\tcrank\tstatus')
    assert text[1].startswith('0\t0\tok') and text[2].startswith('1\t1e-09\tok')


def test_sweep_grid_is_lazy_and_first_axis_slowest():
    import itertools

    huge = cli_common.parse_known('--set', 'a=0:1:1000000000001', True)[1]
    head = list(itertools.islice(cli_common.command_grid([huge, [5.0, 6.0], [7.0]]), 3))
    assert head == [(0.0, 5.0, 7.0), (0.0, 6.0, 7.0), (1e-12, 5.0, 7.0)]
    small = [[1, 2], cli_common.parse_known('--set', 'b=0:1:3', True)[1]]
    assert list(cli_common.command_grid(small)) == list(itertools.product(*small))
    assert list(cli_common.command_grid([])) == [()]


# ---- 3. solver knowns and branch signs, the node's settings, echoed values ------------------


def test_two_known_points_on_one_link_are_its_pose_and_more_knowns_are_refused():
    """The lecture moves the excavator bin by giving J and K: 3 values (its pose), solved as K
    and the bin's angle (test_point_pairs checks the positions); a known beyond that is refused
    with the count, saying what two points of one link give."""
    mech = Scene.from_yaml(scenes.CONFIG / 'excavator.yaml').mechanism
    from linkage_ros.core.errors import PlanError

    solver = Solver(mech, knowns=['point:K', 'point:J'])
    assert solver.plan_knowns == ['point:K', 'link:bucket'] and solver.knowns == [
        'point:K',
        'point:J',
    ]
    with pytest.raises(PlanError) as err:  # two points on different links: 4 values for 3 DOF
        Solver(mech, knowns=['point:K', 'point:A'])
    assert 'give 4 value(s)' in str(err.value) and 'two points of one link' not in str(err.value)
    with pytest.raises(PlanError) as err:  # the pose and one more value
        Solver(mech, knowns=['point:K', 'point:J', 'Z1'])
    assert 'give 4 value(s) (two points of one link give 3: its pose)' in str(err.value)
    with pytest.raises(PlanError, match='angle of a link twice'):
        Solver(mech, knowns=['point:K', 'point:J', 'link:bucket'])
    ref = Solver(mech).solve({'Z1': 1.5, 'Z2': 1.9, 'Z3': 1.4})
    r = solver.solve({'point:K': ref.points['K'], 'point:J': ref.points['J']})
    assert r.success
    for a in ('Z1', 'Z2', 'Z3'):
        assert r.inputs[a] == pytest.approx(ref.inputs[a], abs=1e-9)


def test_explicit_branch_signs_for_a_plan_without_branching_dyads_say_so():
    """The four-bar solved from its coupler angle places every link without a branch choice:
    explicit signs are then refused with a reason that says there is none to give (the message
    used to end in an empty list)."""
    from linkage_ros.core.errors import PlanError

    mech = Scene.from_yaml(scenes.CONFIG / 'four_bar.yaml').mechanism
    assert not Solver(mech, knowns=['coupler']).plan.branch_steps
    with pytest.raises(PlanError) as err:
        Solver(mech, knowns=['coupler'], branch='+')
    assert str(err.value) == (
        "branch '+' has 1 sign(s) but this solve has no branching dyad (no sign to give)"
    )
    with pytest.raises(PlanError) as err:  # with dyads: they are listed
        Solver(mech, knowns=['crank'], branch='+-')
    assert '1 branching dyad(s): ' in str(err.value)


def test_the_node_refuses_a_dimension_given_twice():
    from linkage_ros.params import ConfigError, make_config

    with pytest.raises(ConfigError, match="'dimensions'.*given twice"):
        make_config({'dimensions': ['crank.O2-A=0.1', 'crank.O2-A=0.2']})


def test_a_huge_value_or_frame_is_not_echoed_whole():
    """Messages quote at most ECHO_CHARS of what they were given (a 10^5-character frame id or
    parameter value was echoed whole)."""
    from linkage_ros.core.errors import ECHO_CHARS
    from linkage_ros.params import ConfigError, make_config
    from linkage_ros.setting_checks import SETTING_ECHO_CHARS
    from linkage_ros.stamps import frame_error

    huge = 'x' * 100_000
    why = frame_error('target point', huge, 'base_link')
    assert why is not None and len(why) < 300 + ECHO_CHARS
    with pytest.raises(ConfigError) as err:
        make_config({'frame_id': huge + ' '})
    assert len(str(err.value)) < 400 + SETTING_ECHO_CHARS


def test_an_unknown_name_of_a_target_or_trajectory_is_not_echoed_whole():
    """TOPICS.md: every value a status quotes from a request is cut to its first ECHO_CHARS
    characters. ~/command's unknown names were; ~/target's and a trajectory's (resolved by
    core.model.names) were quoted whole: a 1 MB joint name gave a 1 MB status and a 1 MB
    /diagnostics last_error every second."""
    from linkage_ros.core.errors import ECHO_CHARS
    from linkage_ros.engine import Engine, EngineSettings
    from linkage_ros.trajectory import solve_trajectory

    engine = Engine(scenes.load('four_bar'), EngineSettings())
    huge = 'x' * 1_000_000
    for why in (
        engine.target({huge: 0.1}).reason,
        engine.target({'q' * 900: 0.1}, allow_mode_change=True).reason,
        solve_trajectory(engine, [huge], np.array([[0.3]])).reason,
        solve_trajectory(engine, ['crank', huge], np.array([[0.3, 0.1]])).reason,
    ):
        assert why is not None and 'unknown name' in why
        assert len(why) < 100 + ECHO_CHARS, len(why)
