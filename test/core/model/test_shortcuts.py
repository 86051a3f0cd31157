"""The shortcut forms (core.model.shortcuts): what they refuse is named by their own keys, not
by the general form's they are compiled into (a four_bar file has no `links`)."""

from __future__ import annotations

import pytest

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene

LENGTHS = {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}


@pytest.mark.parametrize(('distance', 'on'), [(0, 'A'), (0.25, 'B')])
def test_a_coupler_point_on_a_or_b_is_refused_under_its_own_key(distance, on):
    """At distance 0 the point is A; at the coupler's length (angle 0), B."""
    data = {'four_bar': {**LENGTHS, 'coupler_point': {'distance': distance}}}
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data)
    assert info.value.key == 'four_bar.coupler_point.distance'
    assert info.value.value == distance
    text = str(info.value)
    assert f': puts P on {on} (at [' in text and f'publish {on} itself (outputs: [{on}])' in text
    assert 'links.' not in text


def test_the_point_a_itself_is_published_by_outputs():
    """The way out the refusal offers loads and publishes A."""
    mech = Scene.from_dict({'four_bar': LENGTHS, 'outputs': ['A']}).mechanism
    assert mech.outputs == ('A',)
