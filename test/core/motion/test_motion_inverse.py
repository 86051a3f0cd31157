"""Tests of linkage_ros.core.motion's inverse kinematics on the shipped scenes: targets reached
by a forward solve come back (round trips), and unreachable or beyond-limit targets are refused
with a reason.
"""

import math

import numpy as np
import pytest
from motion_helpers import circ, named_scene

from linkage_ros.core import motion
from linkage_ros.core.plan import spec_for
from linkage_ros.core.quantities import AngleSpec, PointSpec, SlideSpec
from linkage_ros.core.solver import Solver

# ---- inverse kinematics round trips on the shipped scenes ---------------------------------------


def _target_value(mech, name, r):
    """The value of known `name` (a point, a link angle or a joint value) in a solved Result."""
    spec = spec_for(mech, name)
    if isinstance(spec, PointSpec):
        return np.asarray(r.points[spec.point])
    if isinstance(spec, SlideSpec):
        return r.joints[spec.joint]
    bare = name.split(':')[-1]
    return r.links[bare] if bare in mech.links and spec.reference == mech.ground else r.joints[bare]


def _err(mech, name, a, b):
    """Round-trip error: angles on the circle (rad), lengths as a fraction of the scale."""
    spec = spec_for(mech, name)
    if isinstance(spec, PointSpec):
        return float(np.hypot(*(np.asarray(a) - np.asarray(b)))) / mech.length_scale
    if isinstance(spec, AngleSpec):
        return circ(a, b)
    return abs(a - b) / mech.length_scale


ROUND_TRIPS = [
    ('four_bar', lambda m: [motion.link_key(m, 'rocker')]),
    ('slider_crank', lambda m: ['slider']),
    ('plagiograph', lambda m: [motion.point_key(m, 'D')]),
    ('front_loader', lambda m: [motion.point_key(m, 'D')]),
    ('excavator', lambda m: [motion.point_key(m, 'J'), motion.link_key(m, 'bucket')]),
    ('excavator', lambda m: [motion.point_key(m, 'K'), motion.link_key(m, 'bucket')]),
]


@pytest.mark.parametrize('scene,knowns', ROUND_TRIPS)
def test_inverse_kinematics_round_trip_on_shipped_scenes(scene, knowns):
    mech = named_scene(scene)
    keys = knowns(mech)
    fwd = Solver(mech, branch='reference')
    inv = Solver(mech, knowns=keys, branch='reference')
    rng = np.random.default_rng(11)
    ranges = {a: motion.actuator_range(mech, a) for a in mech.actuators}
    tested = 0
    for _ in range(12):
        cmd = {}
        for a, info in ranges.items():
            lo, hi = info['min'], info['max']
            if lo is None:
                lo, hi = -math.pi, math.pi
            cmd[a] = float(rng.uniform(lo, hi))
        r = fwd.solve(cmd)
        assert r.success, r.reason
        target = {
            k: (
                _target_value(mech, k, r).tolist()
                if np.ndim(_target_value(mech, k, r))
                else _target_value(mech, k, r)
            )
            for k in keys
        }
        answers = [x for x in inv.solve_all(target) if x.success]
        assert answers, inv.solve(target).reason
        for x in answers:
            # forward(inverse(x)) = x: the actuator values reproduce the target in some mode
            back = Solver(mech).solve_all(x.inputs)
            worst = min(
                max(_err(mech, k, _target_value(mech, k, b), target[k]) for k in keys)
                for b in back
                if b.success
            )
            assert worst < 1e-10, (cmd, target, x.inputs)
        tested += 1
    assert tested == 12


@pytest.mark.parametrize('scene,knowns', ROUND_TRIPS)
def test_unreachable_and_beyond_limit_targets_are_refused_with_a_reason(scene, knowns):
    mech = named_scene(scene)
    keys = knowns(mech)
    inv = Solver(mech, knowns=keys)
    # unreachable: points far away, link / slider values outside the motion
    far = {}
    for k in keys:
        bare = k.split(':')[-1]
        if bare in mech.points and (k.startswith('point:') or bare not in mech.links):
            far[k] = [100.0 * mech.length_scale, -100.0 * mech.length_scale]
        elif bare in mech.links:
            lo, hi = motion.oscillation_range(mech, bare) if mech.dof == 1 else (None, None)
            far[k] = (lo + hi) / 2 + math.pi if lo is not None else 0.0
        else:
            far[k] = 100.0 * mech.length_scale
    r = inv.solve(far)
    assert not r.success and r.reason
    assert (
        'close' in r.reason or 'assemble' in r.reason or 'beyond' in r.reason or 'below' in r.reason
    ), r.reason
    # beyond a limit: a pose reached with one actuator past its limit, solved by an unlimited
    # copy, then asked of the limited scene
    limited = [a for a, act in mech.actuators.items() if act.max is not None]
    if not limited:
        return
    a = limited[0]
    act = mech.actuators[a]
    free = motion.without_limits(mech)
    cmd = {b: motion.reference_value(mech, b) for b in mech.actuators}
    span = act.max - (act.min if act.min is not None else act.max - 1.0)
    cmd[a] = act.max + 0.05 * span
    r = Solver(free, branch='reference').solve(cmd)
    assert r.success, r.reason
    target = {k: (np.asarray(_target_value(mech, k, r)).tolist()) for k in keys}
    res = Solver(mech, knowns=keys, branch='reference').solve(target)
    assert not res.success
    assert a in res.reason and 'maximum' in res.reason, res.reason
