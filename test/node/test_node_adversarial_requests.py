"""Adversarial tests of ``linkage_node``: bad requests of every kind on ~/command, ~/target and
~/target_point/<p> (non-finite point targets, a barrage on a 3-DOF scene, more names than the
scene has, a target in the other assembly mode, a huge quaternion), each refused with nothing
changed.

The rule under test (docs/TOPICS.md, "Error behaviour"): a bad request gets exactly one ERROR
status naming what is wrong and nothing else, the node keeps its last good state, and the next
good request works; joint_states always carries every joint with finite values.

The node runs in this process (adversary_helpers.Served), over real DDS on this module's random
domain.
"""

from __future__ import annotations

import math

import pytest
from adversary_helpers import OK, in_frame, joint_state, point_stamped, stamp_next
from ros_harness import random_domain_id
from scenes import CONFIG

from linkage_ros.node import load_engine, make_config

DOMAIN_ID = random_domain_id()
HARNESS_NAME = 'linkage_adversary'


# ---- non-finite point targets ---------------------------------------------------------------


def test_point_target_with_a_non_finite_coordinate_is_refused(serve):
    """z is ignored, but a NaN or inf z is a broken message: it used to be solved as if fine."""
    s = serve(scene=str(CONFIG / 'plagiograph.yaml'))
    acts = list(s.mech.actuators)
    mid = [0.5 * (a.min + a.max) for a in s.mech.actuators.values()]
    before = s.good('command', joint_state(acts, mid, stamp_next()))
    d = s.node.engine.last.points['D']
    goal = (d[0] + 0.002, d[1] - 0.001)
    for (x, y, z), fragments in (
        ((*goal, math.nan), ['point.z = nan']),
        ((*goal, -math.inf), ['point.z = -inf']),
        ((math.nan, goal[1], 0.0), ['point.x = nan']),
        ((goal[0], math.inf, math.nan), ['point.y = inf', 'point.z = nan']),
    ):
        message = s.bad(
            'target_point/D',
            point_stamped(x, y, z, stamp=stamp_next()),
            fragments + ["'D'"],
            ('command', joint_state(acts, mid, stamp_next())),
        )
        assert s.joints.last.position.tolist() == before, message
    # the next good point target is met exactly (a finite z is ignored)
    s.good('target_point/D', point_stamped(*goal, z=5.0, stamp=stamp_next()))
    x, y = s.node.engine.last.points['D']
    assert math.dist((x, y), goal) < 1e-12


# ---- a barrage of bad requests on a 3-DOF scene: nothing changes -----------------------------


def test_bad_requests_change_nothing_on_a_three_dof_scene(serve):
    """Every kind of bad request on ~/command, ~/target and ~/target_point/<p>, interleaved with
    good ones, on the excavator (3 DOF, target_point_hold [bucket]). Each is refused with one
    ERROR naming the problem; the good answers are exactly those of a reference engine fed with
    the good requests alone (so no bad request moved the state, the assembly mode or the held
    bucket angle)."""
    params = {'scene': str(CONFIG / 'excavator.yaml'), 'target_point_hold': ['bucket']}
    s = serve(**params)
    _, ref = load_engine(make_config(params))
    mech = s.mech
    acts = list(mech.actuators)  # Z1, Z2, Z3 (cylinder lengths)
    lo = {a: x.min for a, x in mech.actuators.items()}
    hi = {a: x.max for a, x in mech.actuators.items()}
    mid = {a: 0.5 * (lo[a] + hi[a]) for a in acts}

    def cmd(values, stamp=None, **kw):
        return joint_state(list(values), list(values.values()), stamp or stamp_next(), **kw)

    def check_good(topic, msg, solve):
        got = s.good(topic, msg)
        r = solve()
        assert r.success, r.reason
        assert got == [r.joints[j] for j in mech.joint_names]
        return got

    def probe():
        return 'command', cmd(mid)

    check_good('command', cmd(mid), lambda: ref.command(mid))
    nan_mid = dict(mid, Z2=math.nan)
    bad = [
        ('command', cmd(nan_mid), ['Z2', 'finite', 'nan']),
        ('command', cmd(dict(mid, Z3=math.inf)), ['Z3', 'finite', 'inf']),
        # a command's velocity: empty or one finite rate per name
        ('command', cmd(mid, velocity=[math.nan]), ['3 name(s) but 1 velocities']),
        ('command', cmd(mid, velocity=[0.1, math.inf, 0.0]), ["['Z2']", 'not finite']),
        ('command', cmd(dict(mid, Z1=-math.inf)), ['Z1', 'finite']),
        ('command', joint_state([], [], stamp_next()), ['empty JointState']),
        ('command', joint_state(acts, [1.5, 1.9], stamp_next()), ['3 name(s)', '2 position(s)']),
        (
            'command',
            joint_state(['Z1'], [1.5, 1.9, 1.4], stamp_next()),
            ['1 name(s)', '3 position(s)'],
        ),
        (
            'command',
            joint_state(['Z1', 'Z2', 'Z1'], [1.5, 1.9, 1.6], stamp_next()),
            ["['Z1'] more than once"],
        ),
        (
            'command',
            joint_state(['Z1', '', 'Z3'], [1.5, 1.9, 1.4], stamp_next()),
            ['name[1]', 'empty'],
        ),
        ('command', cmd({'Z1': 1.5, 'Z2': 1.9, 'Z4': 1.4}), ["unknown name(s) ['Z4']"]),
        # a link on ~/command: the hint names the request that takes it (as the CLI's --set)
        (
            'command',
            cmd({'Z1': 1.5, 'Z2': 1.9, 'bucket': 1.4}),
            ["['bucket'] not an actuator", 'use ~/target for joints and links'],
        ),
        ('command', cmd({'Z1': 1.5, 'wrench': 1.0}), ['unknown', 'wrench']),  # partial + unknown
        ('command', cmd(dict(mid, Z1=hi['Z1'] + 0.1)), ['Z1', 'maximum']),
        ('command', cmd(dict(mid, Z3=lo['Z3'] - 0.05)), ['Z3', 'minimum']),
        ('command', cmd(dict(mid, Z2=-1e300)), ['Z2', 'minimum']),
        ('command', cmd(mid, stamp=(-1, 0)), ['header.stamp is negative']),
        ('target', cmd({'bucket': 0.1}), ['3 degree(s) of freedom', 'give 1 value']),
        ('target', cmd({'bucket': 0.1, 'stick': 0.2, 'boom': math.nan}), ['boom', 'finite']),
        ('target', cmd({'bucket': 0.1, 'stick': 0.2, 'shovel': 0.3}), ["'shovel'"]),
        ('target', cmd({'bucket': 0.1, 'stick': 0.2, 'ground': 0.3}), ['ground link']),
        # link angles are absolute: from +x of the frame they are given in
        (
            'target',
            in_frame(cmd({'bucket': 0.1, 'stick': 0.2, 'boom': 0.3}), 'map'),
            ["'map'", mech.frame_id],
        ),
        (
            'target',
            cmd({'Z1': 1.5, 'Z2': 1.9, 'Z3': 1.2, 'bucket': 0.0}),
            ['3 degree(s) of freedom', 'give 4 value'],
        ),
        # unreachable: the boom's angle needs a throw below Z2's limit; L 40 m away
        ('target', cmd({'boom': 3.0, 'stick': 0.0, 'bucket': 0.0}), ['needs Z2', 'minimum']),
        ('target_point/L', point_stamped(40.0, 40.0, stamp=stamp_next()), ['out of reach']),
        (
            'target_point/L',
            point_stamped(2.0, 0.5, stamp=stamp_next(), frame_id='map'),
            ["'map'", mech.frame_id],
        ),
        ('target_point/L', point_stamped(math.nan, 0.5, stamp=stamp_next()), ['point.x = nan']),
        (
            'target_point/L',
            point_stamped(2.0, 0.5, math.inf, stamp=stamp_next()),
            ['point.z = inf'],
        ),
        ('target_point/L', point_stamped(2.0, 0.5, stamp=(3, 10**9)), ['header.stamp.nanosec']),
    ]
    # effort (even NaN, even of another length) is ignored
    step = dict(mid, Z1=mid['Z1'] + 0.02)
    check_good(
        'command',
        cmd(step, effort=[math.nan, 2.0, 3.0, 4.0]),
        lambda: ref.command(step),
    )
    for i, (topic, msg, fragments) in enumerate(bad):
        s.bad(topic, msg, fragments, probe())
        ref.command(mid)  # the probe, on the reference too
        if i % 6 == 5:  # good requests in between, of every kind
            L = ref.last.points['L']
            goal = (L[0] + 0.01 * (i % 4), L[1] - 0.005)
            check_good(
                'target_point/L',
                point_stamped(*goal, stamp=stamp_next()),
                lambda: ref.target_point('L', goal),
            )
            assert math.dist(s.node.engine.last.points['L'], goal) < 1e-9
            bucket = ref.last.links['bucket']
            t = {
                'boom': ref.last.links['boom'] + 0.01,
                'stick': ref.last.links['stick'],
                'bucket': bucket,
            }
            check_good('target', cmd(t), lambda: ref.target(t))
    assert s.node.engine.last.joints == ref.last.joints


def test_a_request_with_more_names_than_the_scene_has_is_refused_at_once(serve):
    """A 10^5-name message used to be checked name by name (and its reason listed them all);
    now the count alone refuses it, before any per-name work, on the node and in the bag tool
    alike (the same engine check), with a short reason; the state is unchanged."""
    from linkage_ros.request_checks import max_request_names, request_shape_error

    s = serve(scene='four_bar')
    limit = max_request_names(s.mech)
    names = [f'n{k}' for k in range(10**5)]

    class CountOnly:  # a name list that fails if the check looks at any single name
        def __len__(self):
            return len(names)

        def __getitem__(self, i):
            raise AssertionError('the count alone must refuse it')

    why = request_shape_error(CountOnly(), len(names), limit)
    assert why == (
        f'JointState has 100000 name(s); the scene has only {limit} names '
        '(actuators, joints, links, and points as <point>.x and <point>.y) to give values for'
    )
    before = s.good('command', joint_state(['crank'], [0.7], (71, 0)))
    for topic in ('command', 'target'):
        msg = s.bad(
            topic,
            joint_state(names, [0.5] * len(names), (72, 0)),
            [why],
            ('command', joint_state(['crank'], [0.7], (73 + (topic == 'target'), 0))),
        )
        assert len(msg) < 300
    assert s.good('command', joint_state(['crank'], [0.7], (80, 0))) == before


def test_a_target_in_the_other_assembly_mode_is_refused_unless_asked_for(serve):
    """On the node: ~/target B = -1.2 (only the other mode reaches it) is refused and changes
    nothing (crank = 1.0 then gives the fresh node's joints); the same on ~/target_any_mode is
    answered, its status says mode_change '+ -> - (another circuit)' (a crank-rocker's other
    sign is its other curve), and commands continue in that mode."""
    s = serve(scene='four_bar')
    fresh = s.good('command', joint_state(['crank'], [1.0], (91, 0)))
    msg = s.bad(
        'target',
        joint_state(['B'], [-1.2], (92, 0)),
        ['target is reachable only in another circuit', 'the mechanism is in mode +'],
        ('command', joint_state(['crank'], [1.0], (93, 0))),
    )
    assert 'ask for the change explicitly' in msg and '~/target_any_mode' in msg
    assert s.good('command', joint_state(['crank'], [1.0], (94, 0))) == fresh
    status = s.send('target_any_mode', joint_state(['B'], [-1.2], (95, 0)))
    assert status.level == OK, status.message
    kv = {v.key: v.value for v in status.values}
    assert kv['mode_change'] == '+ -> - (another circuit)' and kv['request'] == 'target_any_mode'
    other = s.good('command', joint_state(['crank'], [1.0], (96, 0)))
    assert not all(math.isclose(a, b, abs_tol=1e-9) for a, b in zip(other, fresh))
    status = s.send('command', joint_state(['crank'], [1.1], (97, 0)))
    assert {v.key: v.value for v in status.values}['branch'] == '-'


def test_a_huge_quaternion_is_normalised_without_overflow():
    """(1e300, 0, 0, 1e300) is a rotation about x by 90 deg: refused as not planar. Its squares
    overflowed, the normalised quaternion became 0 and the pose was read as yaw 0."""
    from geometry_msgs.msg import PoseStamped

    from linkage_ros.conversions import pose_to_xy_yaw
    from linkage_ros.core.errors import CommandError

    msg = PoseStamped()
    q = msg.pose.orientation
    q.x, q.y, q.z, q.w = 1e300, 0.0, 0.0, 1e300
    with pytest.raises(CommandError, match='not a rotation about z'):
        pose_to_xy_yaw(msg, 'bucket')
    q.x, q.z, q.w = 0.0, 1e300, 1e300  # yaw 90 deg, scaled
    assert pose_to_xy_yaw(msg, 'bucket')[2] == pytest.approx(math.pi / 2, abs=1e-15)
