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


FOUR_BAR_POINTS = {'O2': [0, 0], 'A': [0.05, 0.0866], 'B': [0.32, 0.19], 'O4': [0.3, 0]}
FOUR_BAR_LINKS = {'ground': ['O2', 'O4'], 'crank': ['O2', 'A'], 'coupler': ['A', 'B']}
CRANK = {'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2'}}


def dof_refusal(data) -> str:
    with pytest.raises(SceneError) as info:
        Scene.from_dict(data)
    assert info.value.key == 'actuators'
    return str(info.value)


def test_a_floating_link_is_named_in_the_dof_refusal():
    data = {
        'points': {**FOUR_BAR_POINTS, 'X': [1, 1], 'Y': [1.2, 1.1]},
        'links': {**FOUR_BAR_LINKS, 'rocker': ['O4', 'B'], 'floating': ['X', 'Y']},
        'actuators': CRANK,
    }
    assert dof_refusal(data) == (
        '<scene>: actuators: the mechanism has 4 degree(s) of freedom (Kutzbach 3(n-1)-2j with '
        "n=5 links, j=4 joints) but 1 actuator(s); no chain of joints joins link 'floating' to "
        "the ground link 'ground' (got ['crank'])"
    )


def test_floating_links_joined_to_each_other_only_are_named_five_at_most():
    """A chain of 7 links pinned end to end, none to the ground: each is named, 5 at most."""
    points = {**FOUR_BAR_POINTS, **{f'C{k}': [2.0 + k, 1.0] for k in range(8)}}
    chain = {f'c{k}': [f'C{k}', f'C{k + 1}'] for k in range(7)}
    data = {
        'points': points,
        'links': {**FOUR_BAR_LINKS, 'rocker': ['O4', 'B'], **chain},
        'actuators': CRANK,
    }
    text = dof_refusal(data)
    assert 'n=11 links, j=10 joints' in text
    assert (
        "no chain of joints joins links 'c0', 'c1', 'c2', 'c3', 'c4' and 2 more to the ground "
        "link 'ground'" in text
    )


def test_a_pin_given_twice_under_two_names_is_named_in_the_dof_refusal():
    data = {
        'points': {**FOUR_BAR_POINTS, 'B2': [0.32, 0.19]},
        'links': {**FOUR_BAR_LINKS, 'rocker': ['O4', 'B2']},
        'actuators': CRANK,
    }
    assert dof_refusal(data) == (
        '<scene>: actuators: the mechanism has 3 degree(s) of freedom (Kutzbach 3(n-1)-2j with '
        'n=4 links, j=3 joints) but 1 actuator(s); points B and B2 are drawn on one spot but are '
        "two points, so no joint joins them: if they are one pin, give it one name (got ['crank'])"
    )


def test_a_dof_refusal_with_every_link_joined_has_no_hint():
    data = {
        'points': FOUR_BAR_POINTS,
        'links': {**FOUR_BAR_LINKS, 'rocker': ['O4', 'B']},
        'actuators': {**CRANK, 'extra': {'type': 'angle', 'link': 'rocker', 'pivot': 'O4'}},
    }
    assert dof_refusal(data).endswith("but 2 actuator(s) (got ['crank', 'extra'])")


def test_a_misspelt_top_key_is_told_every_key_a_scene_file_may_have():
    """The keys an unknown top-level key's message lists are the scene file's, joint_coordinates
    (what linkage import writes) among them; it was left out, so its misspelling got no hint.
    Every key listed is one SCENES.md documents."""
    import ast
    from pathlib import Path

    fb = {'ground': 0.3, 'crank': 0.1, 'coupler': 0.25, 'rocker': 0.2}
    with pytest.raises(SceneError, match='joint_cordinates: unknown key') as err:
        Scene.from_dict({'four_bar': fb, 'joint_cordinates': {}})
    msg = str(err.value)
    listed = ast.literal_eval(msg[msg.index('[') : msg.index(']') + 1])
    assert 'joint_coordinates' in listed
    doc = (Path(__file__).parents[3] / 'docs' / 'SCENES.md').read_text()
    assert [k for k in listed if f'`{k}`' not in doc and f'{k}:' not in doc] == []
