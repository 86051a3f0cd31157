"""The one name-resolution rule (core.model.names) and every reader that uses it: the solver's
knowns (plan.spec_for), values read off a result (solver.result.named_value, the engine's held
values), the engine's target_point_hold check, the motion analyses' keys and the plots'
outputs. The oracle is the documented order, written out here: actuator, joint, link, point."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scenes

from linkage_ros.core.errors import PlanError
from linkage_ros.core.model import Scene
from linkage_ros.core.model.names import NameKind, point_coordinate, resolve_name
from linkage_ros.core.motion import link_key, point_key
from linkage_ros.core.plan import spec_for, spec_value_one
from linkage_ros.core.quantities import AngleSpec, PointSpec, SlideSpec
from linkage_ros.core.solver import Solver
from linkage_ros.core.solver.reading import configuration_of
from linkage_ros.core.solver.result import named_value
from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.setting_checks import ConfigError

SHIPPED = ['four_bar', 'excavator', 'quick_return', 'slider_crank', 'peaucellier']


def documented_kind(mech, name: str) -> NameKind:
    """The order docs/SCENES.md and the solver state, written independently of the code."""
    if name in mech.actuators:
        return NameKind.ACTUATOR
    if name in [j.name for j in mech.revolutes] or name in mech.prismatics:
        return NameKind.JOINT
    if name in mech.links:
        return NameKind.LINK
    assert name in mech.points
    return NameKind.POINT


def every_name(mech) -> list[str]:
    return sorted(set(mech.actuators) | set(mech.joint_names) | set(mech.links) | set(mech.points))


@pytest.mark.parametrize('stem', SHIPPED)
def test_bare_and_prefixed_names_resolve_in_the_documented_order(stem):
    mech = scenes.load(stem)
    for name in every_name(mech):
        kind = documented_kind(mech, name)
        assert resolve_name(mech, name).kind is kind, name
        for explicit in NameKind:
            present = {
                NameKind.ACTUATOR: mech.actuators,
                NameKind.JOINT: mech.joint_names,
                NameKind.LINK: mech.links,
                NameKind.POINT: mech.points,
            }[explicit]
            if name in present:
                got = resolve_name(mech, f'{explicit.value}:{name}')
                assert (got.kind, got.name) == (explicit, name)
            else:
                with pytest.raises(PlanError, match=f'has no {explicit.value} named'):
                    resolve_name(mech, f'{explicit.value}:{name}')
    with pytest.raises(PlanError, match='unknown name'):
        resolve_name(mech, 'no_such_name')
    with pytest.raises(PlanError, match='unknown kind'):
        resolve_name(mech, 'frame:O2')


@pytest.mark.parametrize('stem', SHIPPED)
def test_a_known_spec_and_a_value_read_off_a_result_mean_the_same_quantity(stem):
    """spec_for (what a solver takes) and named_value (what the engine holds) of one name read
    the same number off one configuration: a different resolution order in either would read a
    joint as a point (a pair against a float) or a link angle as an actuator's."""
    mech = scenes.load(stem)
    solver = Solver(mech)
    res = solver.solve(solver.reference_values())
    assert res.success
    _, poses = configuration_of(solver.compiled, res)
    names = [n for n in every_name(mech) if n != mech.ground]
    names += [f'point:{p}' for p in mech.points] + [f'link:{l}' for l in mech.moving_links]
    for name in names:
        spec = spec_for(mech, name)
        held = named_value(mech, res, name)
        from_spec = spec_value_one(mech, spec, poses)
        if isinstance(spec, PointSpec):
            np.testing.assert_allclose(held, from_spec, atol=1e-12 * mech.length_scale)
        else:
            assert isinstance(spec, AngleSpec | SlideSpec)
            diff = held - from_spec
            if isinstance(spec, AngleSpec):
                diff = math.remainder(diff, 2 * math.pi)
            assert abs(diff) < 1e-12 * max(1.0, mech.length_scale), name


@pytest.mark.parametrize('stem', SHIPPED)
def test_motion_keys_resolve_back_to_the_named_point_and_link(stem):
    mech = scenes.load(stem)
    for p in mech.points:
        got = resolve_name(mech, point_key(mech, p))
        assert (got.kind, got.name) == (NameKind.POINT, p)
        # bare only where nothing earlier in the order takes the name
        assert (point_key(mech, p) == p) == (documented_kind(mech, p) is NameKind.POINT)
    for l in mech.moving_links:
        got = resolve_name(mech, link_key(mech, l))
        assert (got.kind, got.name) == (NameKind.LINK, l)


def test_point_coordinates_name_a_point_and_an_axis():
    mech = scenes.load('four_bar')
    assert point_coordinate(mech, 'P.x') == ('P', 0)
    assert point_coordinate(mech, 'P.y') == ('P', 1)
    assert point_coordinate(mech, 'P.z') is None
    assert point_coordinate(mech, 'nowhere.x') is None
    assert point_coordinate(mech, 'P') is None


def test_held_names_take_prefixes_and_count_a_point_as_two_values():
    """target_point_hold resolves like the solver: ``K`` of the excavator is the stick-bucket
    joint (1 value: with the point target, its 3 degrees of freedom), ``point:K`` the point (2
    values: too many), ``link:bucket`` the bucket's angle. The engine's own order refused every
    prefixed name as unknown."""
    mech = scenes.load('excavator')
    Engine(mech, EngineSettings(target_point_hold=('K',)))
    with pytest.raises(ConfigError, match='must give the 3 degree'):
        Engine(mech, EngineSettings(target_point_hold=('point:K',)))
    with pytest.raises(ConfigError, match='unknown name'):
        Engine(mech, EngineSettings(target_point_hold=('link:ground',)))
    engine = Engine(mech, EngineSettings(target_point_hold=('link:bucket',)))
    before = engine.last
    assert before is not None
    x, y = before.points['L']
    got = engine.target_point('L', (x + 0.05, y - 0.05))
    assert got.success, got.reason
    np.testing.assert_allclose(got.points['L'], (x + 0.05, y - 0.05), atol=1e-9)
    assert abs(math.remainder(got.links['bucket'] - before.links['bucket'], 2 * math.pi)) < 1e-9


def test_a_plotted_output_named_like_an_actuator_and_a_link_is_the_actuator(tmp_path):
    """Resolved as the solver resolves it: ``crank`` is the actuator (here the direction
    O2 -> C, 45 degrees off the link's axis O2 -> A), so the actuator plotted against itself is
    the identity; the plots' own order (link first) drew the link's angle, 45 degrees off."""
    from linkage_ros.plots import plot_output_vs_input

    mech = Scene.from_dict(
        {
            'name': 'clash',
            'points': {
                'O2': [0.0, 0.0],
                'A': [0.1, 0.0],
                'C': [0.05, 0.05],
                'B': [0.32, 0.19],
                'O4': [0.3, 0.0],
            },
            'links': {
                'ground': ['O2', 'O4'],
                'crank': ['O2', 'A', 'C'],
                'coupler': ['A', 'B'],
                'rocker': ['O4', 'B'],
            },
            'actuators': {
                'crank': {'type': 'angle', 'link': 'crank', 'pivot': 'O2', 'toward': 'C'}
            },
        }
    ).mechanism
    d = plot_output_vs_input(mech, 'crank', 'crank', tmp_path / 'crank.png', samples=73)
    for br in d['branches'].values():
        t_in, t_out = np.asarray(br['input']), np.asarray(br['output'])
        assert t_in.size
        np.testing.assert_allclose(np.remainder(t_out - t_in + math.pi, 2 * math.pi), math.pi)


def test_wanted_outputs_take_prefixed_names():
    """Solver(outputs=...) prunes the plan to what the outputs need: a prefixed name picks the
    kind as a known's does (the outputs' own rule refused ``point:K`` as unknown). The pruned
    answers equal the full solve's."""
    mech = scenes.load('excavator')
    full = Solver(mech)
    ref = full.solve(full.reference_values())
    for outputs, read in (
        (['point:K'], lambda r: r.points['K']),
        (['K'], lambda r: r.points['K']),
        (['link:bucket'], lambda r: r.links['bucket']),
    ):
        pruned = Solver(mech, outputs=outputs)
        got = pruned.solve(pruned.reference_values())
        assert got.success, got.reason
        np.testing.assert_allclose(read(got), read(ref), atol=1e-12)
    with pytest.raises(PlanError, match='unknown output'):
        Solver(mech, outputs=['frame:K'])
