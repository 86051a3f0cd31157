"""Adversarial tests of ``linkage_node``: requests in bursts, commands and targets alternating,
rocker targets up to and past the toggle, and a seeded random mix of good, extreme and bad
values: one status per request, every joint_states whole and finite.

The rule under test (docs/TOPICS.md, "Error behaviour"): a bad request gets exactly one ERROR
status naming what is wrong and nothing else, the node keeps its last good state, and the next
good request works; joint_states always carries every joint with finite values.

The node runs in this process (adversary_helpers.Served), over real DDS on this module's random
domain.
"""

from __future__ import annotations

import math
import random

from adversary_helpers import (
    DEEP,
    ERROR,
    OK,
    TIMEOUT,
    FourBar,
    assert_close_angles,
    joint_state,
    point_stamped,
    stamp_next,
    stamp_of,
)
from diagnostic_msgs.msg import DiagnosticStatus
from ros_harness import random_domain_id
from scenes import CONFIG
from sensor_msgs.msg import JointState

from linkage_ros.node import NODE_NAME

DOMAIN_ID = random_domain_id()
HARNESS_NAME = 'linkage_adversary'


# ---- bursts and alternation -----------------------------------------------------------------


def test_burst_and_alternation_of_command_and_target(serve):
    """60 requests back to back, commands and targets alternating: every answer is complete and
    finite and matches the closed form of its own request (matched by stamp); there are as many
    OK statuses as joint_states; all 60 are answered (queue_depth 100 holds the burst)."""
    s = serve(scene='four_bar', queue_depth=100)
    s.good('command', joint_state(['crank'], [0.5], stamp_next()))
    # deep endpoints on our side too, so that our readers keep every answer of the burst
    joints, status = [], []
    ros = s.ros
    ros.node.create_subscription(JointState, f'{s.ns}/joint_states', joints.append, DEEP)
    ros.node.create_subscription(
        DiagnosticStatus, f'{s.ns}/{NODE_NAME}/status', status.append, DEEP
    )
    cmd = ros.node.create_publisher(JointState, f'{s.ns}/{NODE_NAME}/command', DEEP)
    tgt = ros.node.create_publisher(JointState, f'{s.ns}/{NODE_NAME}/target', DEEP)
    assert ros.spin_until(
        lambda: (
            s.node.outputs.pub_joints.get_subscription_count() >= 2
            and s.node.outputs.pub_status.get_subscription_count() >= 2
            and cmd.get_subscription_count()
            and tgt.get_subscription_count()
        ),
        TIMEOUT,
    )
    sent = {}
    for i in range(60):
        theta2 = -math.pi + 2 * math.pi * i / 60 + 0.01
        want = FourBar.joints(theta2)
        stamp = (50_000 + i, 7)
        if i % 2:
            tgt.publish(joint_state(['O2'], [want[0]], stamp))  # a joint target
        else:
            cmd.publish(joint_state(['crank'], [theta2], stamp))
        sent[stamp] = want
    last = (50_059, 7)
    # (two topics: the last one sent may be taken before others; every one is answered)
    assert ros.spin_until(lambda: len(joints) >= 60 and len(status) >= 60, TIMEOUT), len(joints)
    assert any(stamp_of(j) == last for j in joints)
    assert len(joints) == 60
    assert len(set(map(stamp_of, joints))) == len(joints), 'one answer per request'
    for js in joints:
        assert list(js.name) == ['O2', 'A', 'B', 'O4']
        assert all(math.isfinite(v) for v in js.position)
        assert_close_angles(js.position, sent[stamp_of(js)])
    assert [st.level for st in status] == [OK] * len(joints)


def test_rocker_targets_up_to_and_past_the_toggle(serve):
    """The four-bar's rocker swings between two toggle positions. Targets walked up to the
    extreme are met; one past it is refused (it does not assemble) and changes nothing; walking
    back works. Every answer is whole and finite."""
    s = serve(scene='four_bar')
    grid = [FourBar.joints(2 * math.pi * i / 20000) for i in range(20000)]
    top = max(grid, key=lambda j: j[3])  # the rocker's largest angle from +x
    s.good('command', joint_state(['crank'], [top[0] - 0.3], stamp_next()))
    for o4 in (top[3] - 0.05, top[3] - 1e-3, top[3] - 1e-6):
        got = s.good('target', joint_state(['O4'], [o4], stamp_next()))
        assert abs(got[3] - o4) < 1e-9
        assert_close_angles(got, FourBar.joints(got[0]))  # a real assembly, branch +
    before = got
    for past in (top[3] + 1e-3, top[3] + 0.2, top[3] + math.pi):
        s.bad(
            'target',
            joint_state(['O4'], [past], stamp_next()),
            ['cannot assemble'],
            ('target', joint_state(['O4'], [before[3]], stamp_next())),
        )
        assert_close_angles(s.joints.last.position, before, tol=1e-7)
    got = s.good('target', joint_state(['O4'], [top[3] - 0.05], stamp_next()))
    assert abs(got[3] - (top[3] - 0.05)) < 1e-9


def test_random_requests_always_give_one_status_and_whole_finite_joint_states(serve):
    """A seeded mix of good, extreme and bad values (huge, tiny, beyond limits, NaN) on every
    request topic of the 2-DOF plagiograph: one status per request, and every joint_states has
    every joint, finite."""
    s = serve(scene=str(CONFIG / 'plagiograph.yaml'))
    mech = s.mech
    acts = list(mech.actuators)
    rng = random.Random(20240601)
    extremes = [
        0.0,
        1e-300,
        -1e-300,
        1e300,
        -1e300,
        1e17,
        math.pi,
        -math.pi,
        2 * math.pi,
        math.nan,
        math.inf,
    ]
    names = acts + mech.joint_names + [l for l in mech.links if l != mech.ground]

    def value(now):
        """Mostly a small step from the current value, sometimes an extreme one."""
        return rng.choice(extremes) if rng.random() < 0.25 else now + rng.uniform(-0.05, 0.05)

    s.good(
        'command',
        joint_state(acts, [0.5 * (a.min + a.max) for a in mech.actuators.values()], stamp_next()),
    )
    oks = 0
    for i in range(60):
        last = s.node.engine.last  # where the mechanism is: to pick near values
        kind = i % 3
        if kind == 0:
            topic, msg = (
                'command',
                joint_state(acts, [value(last.inputs[a]) for a in acts], stamp_next()),
            )
        elif kind == 1:
            k = rng.sample(names, 2)
            now = {**last.links, **last.joints, **last.inputs}
            topic, msg = 'target', joint_state(k, [value(now[n]) for n in k], stamp_next())
        else:
            x, y = last.points['D']
            topic, msg = 'target_point/D', point_stamped(value(x), value(y), stamp=stamp_next())
        status = s.send(topic, msg)
        if status.level == OK:
            oks += 1
            assert s.ros.spin_until(lambda: len(s.joints) >= 1, TIMEOUT)
            js = s.joints.last
            assert stamp_of(js) == stamp_of(msg)
            assert list(js.name) == mech.joint_names
            assert all(math.isfinite(v) for v in js.position), (topic, msg, list(js.position))
        else:
            assert status.level == ERROR and status.message
        assert len(s.status) == 1
    assert oks >= 10
