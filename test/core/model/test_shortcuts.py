"""The shortcut forms (core.model.shortcuts): what they refuse is named by their own keys, not
by the general form's they are compiled into (a four_bar file has no `links`)."""

from __future__ import annotations

import math
import re

import pytest
from scenes import REPO

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


def test_the_default_input_example_of_scenes_md_is_what_loads():
    """SCENES.md's worked example of the default input, its numbers checked against the loader
    and the toggles by the law of cosines (|O4A| = rocker -+ coupler at the range's ends)."""
    text = (REPO / 'docs' / 'SCENES.md').read_text(encoding='utf-8')
    number = r'([0-9.]+)'
    found = re.search(
        rf'`four_bar: \{{ground: {number}, crank: {number}, coupler: {number}, rocker: {number}\}}`'
        rf' reaches crank angles {number}\s+to {number} rad.*?drawn at crank {number} rad, '
        rf'{number} rad short\s+of the toggle at {number}\.',
        text,
        flags=re.S,
    )
    assert found, 'the example is gone from docs/SCENES.md'
    l1, l2, l3, l4, low, high, drawn, short, toggle = (float(g) for g in found.groups())

    def crank_at(o4a: float) -> float:
        return math.acos((l1 * l1 + l2 * l2 - o4a * o4a) / (2 * l1 * l2))

    assert round(crank_at(l4 - l3), 5) == low
    assert round(crank_at(l4 + l3), 5) == high == toggle
    lengths = {'ground': l1, 'crank': l2, 'coupler': l3, 'rocker': l4}
    a = Scene.from_dict({'four_bar': lengths}).mechanism.points['A']
    theta = math.atan2(a[1], a[0])
    assert round(theta, 5) == drawn
    assert round(crank_at(l4 + l3) - theta, 5) == short
    assert 0 < short <= 0.01  # inside the range, within the step the text states
