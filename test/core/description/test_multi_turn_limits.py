"""A revolute joint whose <limit> spans more than a turn in radians (a wrist's +-4 rad, a
UR-style +-2 pi) is bounded as given and published at the command's own turn: its limits were
dropped as "a full turn or more" (an integrator: 4.5 against [-4, 4] was accepted and
published -1.78; 3.5, inside, was published -2.78, on the other side of the joint's range for
a controller or MoveIt). Limits that read as degrees (an end beyond two turns, the grbda
fixture's +-13.14) still limit nothing, with the import's note. Oracle: Pinocchio's forward
kinematics of the description itself at the published values closes the loop."""

from __future__ import annotations

import math

import pytest
from description_consumers_helpers import CLOSE, FOUR_BAR, PinocchioRobot, described, pin_miss

from linkage_ros.core.description import import_description
from linkage_ros.engine import Engine, EngineSettings

PIN = (('link2', (1.0, 0.0, 0.0)), ('link3', (0.5, 0.0, 0.0)))  # the <loop>'s two frames


@pytest.fixture(scope='module')
def wrist(tmp_path_factory):
    text = FOUR_BAR.read_text().replace('lower="-13.14" upper="13.14"', 'lower="-4" upper="4"')
    assert text.count('lower="-4" upper="4"') == 3
    path = tmp_path_factory.mktemp('wrist') / 'four_bar_4rad.urdf'
    path.write_text(text)
    return path


@pytest.mark.parametrize('q', [3.5, -3.9, 3.9999999, 0.3])
def test_a_command_within_multi_turn_limits_is_published_as_given(wrist, q):
    imp = import_description(str(wrist))
    assert not any('span a full turn' in n for n in imp.notes)
    mech = imp.mechanism
    r = Engine(mech, EngineSettings()).command({'joint1': q})
    assert r.success, r.reason
    values = described(mech, r)
    assert values['joint1'] == q
    assert pin_miss(PinocchioRobot(wrist), values, [PIN]) <= CLOSE


@pytest.mark.parametrize(('q', 'why'), [
    (4.5, 'joint1 = 4.5 rad is beyond its maximum 4 by 0.5 rad'),
    (-4.25, 'joint1 = -4.25 rad is below its minimum -4 by 0.25 rad'),
])  # fmt: skip
def test_a_command_beyond_multi_turn_limits_is_refused(wrist, q, why):
    mech = import_description(str(wrist)).mechanism
    e = Engine(mech, EngineSettings())
    before = dict(e.last.inputs)
    r = e.command({'joint1': q})
    assert not r.success and r.reason.startswith(why), r.reason
    assert e.last.inputs == before


def test_limits_that_read_as_degrees_still_limit_nothing():
    imp = import_description(str(FOUR_BAR))
    assert any('joint1 (-13.14 .. 13.14 rad) span a full turn' in n for n in imp.notes)
    r = Engine(imp.mechanism, EngineSettings()).command({'joint1': 13.5})
    assert r.success, r.reason
    assert math.isclose(described(imp.mechanism, r)['joint1'], math.remainder(13.5, 2 * math.pi))
