"""A redraw that cannot close is refused after a bounded number of closure attempts (issue 27:
a 64-link redraw that could not close took 42-52 s to refuse). Work is counted, not timed: the
continuation halves its step toward the fold and stops at MIN_STEP of the way. The refusal
names where it stopped; oracle: the four-bar stops closing where its shrinking rocker can no
longer reach, rocker = coupler - |A O4| (the triangle inequality, written here)."""

from __future__ import annotations

import math
import re

import pytest

from linkage_ros.bench.scaling import LENGTHS, four_bars_scene
from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene, redraw

SHORT_ROCKER = 0.01  # m: four-bar 0's rocker stated far too short to reach B


def _attempts(monkeypatch) -> list[int]:
    calls = [0]
    close = redraw.close_redraw

    def counted(closure, x0):
        calls[0] += 1
        return close(closure, x0)

    monkeypatch.setattr(redraw, 'close_redraw', counted)
    return calls


@pytest.mark.parametrize('bars', [1, 21])  # 3 and 63 moving links (a redraw takes 64)
def test_a_redraw_that_cannot_close_is_refused_in_bounded_work(monkeypatch, bars):
    scene = four_bars_scene(bars)
    scene['dimensions'] = {'rocker_0.O4_0-B_0': SHORT_ROCKER}
    calls = _attempts(monkeypatch)
    with pytest.raises(SceneError) as err:
        Scene.from_dict(scene)
    # halving from 1/8 of the way toward the fold, each step size tried about twice, down to
    # 1/1024 of the way: under 32 closure attempts (creeping to 2^-20 with the step doubled
    # after every success took 44, each of them seconds for 63 links)
    assert calls[0] <= 32, calls[0]
    # where it stopped: four-bar 0 is drawn with its crank at 0.3 rad
    ground, crank, coupler, rocker = LENGTHS
    reach = abs(complex(ground, 0.0) - crank * complex(math.cos(0.3), math.sin(0.3)))
    fold = (rocker - (coupler - reach)) / (rocker - SHORT_ROCKER)  # fraction of the way
    got = re.search(r'at (\d+)% of the way', str(err.value))
    assert got, str(err.value)
    assert abs(int(got.group(1)) - 100 * fold) <= 1.0, (got.group(1), fold)
    assert 'actuator' in str(err.value)  # a mechanism: its actuators are held
