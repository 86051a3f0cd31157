"""The general form's readers (core.model.general): refusals named by the file's key."""

from __future__ import annotations

import pytest

from linkage_ros.core.errors import SceneError
from linkage_ros.core.model import Scene

FOUR_BAR = {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}


@pytest.mark.parametrize('outputs', [['P', 'P'], ['A', 'P', 'A']])
def test_a_point_listed_twice_in_outputs_is_refused_naming_it(outputs):
    data = {'four_bar': {**FOUR_BAR, 'coupler_point': {'distance': 0.1}}, 'outputs': outputs}
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data)
    repeated = outputs[-1]
    assert str(info.value) == (
        f"<scene>: outputs: lists point '{repeated}' twice; list each point once (got {outputs!r})"
    )


def test_outputs_listed_once_keep_their_order():
    data = {'four_bar': {**FOUR_BAR, 'coupler_point': {'distance': 0.1}}, 'outputs': ['P', 'A']}
    assert Scene.from_dict(data).mechanism.outputs == ('P', 'A')
