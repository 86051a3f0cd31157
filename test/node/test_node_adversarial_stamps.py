"""Adversarial tests of ``linkage_node``: stamps a ROS time cannot hold, refused on every
request, and zero stamps under a simulated clock (before its first tick, and paused).

The rule under test (docs/TOPICS.md, "Error behaviour"): a bad request gets exactly one ERROR
status naming what is wrong and nothing else, the node keeps its last good state, and the next
good request works; joint_states always carries every joint with finite values.

The node runs in this process (adversary_helpers.Served), over real DDS on this module's random
domain.
"""

from __future__ import annotations

import math

from adversary_helpers import (
    OK,
    TIMEOUT,
    FourBar,
    assert_close_angles,
    joint_state,
    point_stamped,
    stamp_next,
    stamp_of,
)
from builtin_interfaces.msg import Time
from ros_harness import random_domain_id
from rosgraph_msgs.msg import Clock
from scenes import CONFIG

DOMAIN_ID = random_domain_id()
HARNESS_NAME = 'linkage_adversary'


# ---- stamps ---------------------------------------------------------------------------------

BAD_STAMPS = {
    'negative': ((-5, 0), ['header.stamp is negative', 'sec = -5']),
    'negative_max': ((-(2**31), 999_999_999), ['header.stamp is negative']),
    'nanosec_1e9': ((7, 1_000_000_000), ['header.stamp.nanosec = 1000000000']),
    'nanosec_max': ((7, 2**32 - 1), ['header.stamp.nanosec = 4294967295']),
}


def test_stamps_a_ros_time_cannot_hold_are_refused_on_every_request(serve):
    """A negative stamp or nanosec >= 1e9 used to be echoed on every answer, where rclpy's
    Time.from_msg (and rclcpp::Time) refuse it. Now: one ERROR naming header.stamp, state kept,
    on ~/command, ~/target and ~/target_point/<p>; the largest valid stamp is echoed unchanged."""
    s = serve(scene=str(CONFIG / 'plagiograph.yaml'))
    mech = s.mech
    acts = list(mech.actuators)
    mid = [0.5 * (a.min + a.max) for a in mech.actuators.values()]
    before = s.good('command', joint_state(acts, mid, stamp_next()))

    def probe():
        return 'command', joint_state(acts, mid, stamp_next())

    d = s.node.engine.last.points['D']
    for case, (stamp, fragments) in BAD_STAMPS.items():
        for topic, msg in (
            ('command', joint_state(acts, [m + 0.01 for m in mid], stamp)),
            ('target', joint_state(['theta_A', 'C'], [0.3, 0.9], stamp)),
            ('target_point/D', point_stamped(d[0] + 0.001, d[1], stamp=stamp)),
        ):
            s.bad(topic, msg, fragments, probe())
            assert s.joints.last.position.tolist() == before, (case, topic)
    # valid extremes: echoed as they are
    for stamp in ((2**31 - 1, 999_999_999), (0, 1), (1, 0)):
        s.good('command', joint_state(acts, mid, stamp))
        assert stamp_of(s.joints.last) == stamp


def test_zero_stamp_under_sim_time_before_the_first_clock(ros, serve):
    """With use_sim_time and no /clock yet, now is 0: a zero stamp was "replaced" by 0 and a zero
    stamp published, against the promise. Now such a request is refused (state kept), a stamped
    one is answered, and once /clock runs a zero stamp becomes the sim time."""
    s = serve(scene='four_bar', use_sim_time=True)
    s.bad(
        'command',
        joint_state(['crank'], [0.7]),
        ['use_sim_time', '/clock'],
        ('command', joint_state(['crank'], [1.0], stamp_next())),
    )
    assert_close_angles(s.joints.last.position, FourBar.joints(1.0))
    clock_pub = ros.node.create_publisher(Clock, '/clock', 10)
    assert ros.spin_until(lambda: clock_pub.get_subscription_count() > 0, TIMEOUT)
    assert ros.spin_until(
        lambda: (
            clock_pub.publish(Clock(clock=Time(sec=4321, nanosec=5)))
            or s.node.get_clock().now().nanoseconds > 0
        ),
        TIMEOUT,
    )
    ros.node.destroy_publisher(clock_pub)
    status = s.send('command', joint_state(['crank'], [0.7]))
    assert status.level == OK, status.message
    assert ros.spin_until(lambda: len(s.joints) == 1, TIMEOUT)
    assert stamp_of(s.joints.last) == (4321, 5)
    assert_close_angles(s.joints.last.position, FourBar.joints(0.7))


def test_an_answer_under_a_paused_sim_clock_comes_after_the_pose_before_it(ros, serve):
    """A sim clock at 101.1 s, then paused: the republication timer sent the pose at 101.1 and
    a zero-stamped command was answered at 101.1 too, the same stamp; tf keeps the first
    transform of a stamp (TF_REPEATED_DATA), so robot_state_publisher kept the old pose (an
    outside adversary). The answer now comes 1 ns after, and the paused clock republishes
    nothing at a stamp it has sent."""
    s = serve(scene='four_bar', use_sim_time=True, publish_rate=10.0)
    clock_pub = ros.node.create_publisher(Clock, '/clock', 10)
    assert ros.spin_until(lambda: clock_pub.get_subscription_count() > 0, TIMEOUT)
    paused = (101, 100_000_000)
    assert ros.spin_until(
        lambda: (
            clock_pub.publish(Clock(clock=Time(sec=paused[0], nanosec=paused[1])))
            or any(stamp_of(m) == paused for m in s.joints.messages)
        ),
        TIMEOUT,
    ), 'no republication at the sim time'
    ros.node.destroy_publisher(clock_pub)
    status = s.send('command', joint_state(['crank'], [1.3]))
    assert status.level == OK, status.message
    assert ros.spin_until(lambda: len(s.joints) >= 1, TIMEOUT)
    answer = s.joints.messages[0]
    assert stamp_of(answer) == (paused[0], paused[1] + 1)
    assert_close_angles(answer.position, FourBar.joints(1.3))
    ros.spin_until(lambda: False, 0.5)  # (five republication periods, were the clock running)
    assert [stamp_of(m) for m in s.joints.messages] == [stamp_of(answer)]
    # a client's stamp in the past is echoed, and the next zero-stamped answer still comes
    # after every stamp sent (a review: it had come back to 101.1 s)
    s.good('command', joint_state(['crank'], [1.2], (100, 0)))
    status = s.send('command', joint_state(['crank'], [1.1]))
    assert status.level == OK, status.message
    assert ros.spin_until(lambda: len(s.joints) >= 1, TIMEOUT)
    assert stamp_of(s.joints.messages[0]) == (paused[0], paused[1] + 2)


def test_a_client_stamp_ahead_of_the_clock_does_not_move_the_nodes_own_stamps(ros, serve):
    """A command stamped an hour ahead, or at the largest valid stamp, is echoed; the node's own
    stamps did follow it (1 ns after the last joint_states): a later zero-stamped command was
    answered an hour in the future, republication stopped until the clock got there, and after
    the largest stamp the 1 ns more overflowed the message: every zero-stamped request failed
    with an internal error (an outside review). Now they stay on the node's clock."""
    s = serve(scene='four_bar', publish_rate=20.0)
    clock = s.node.get_clock()
    for ahead in ((clock.now().nanoseconds // 10**9 + 3600, 0), (2**31 - 1, 999_999_999)):
        status = s.send('command', joint_state(['crank'], [1.2], ahead))  # (republication
        assert status.level == OK, status.message  # runs: not s.good's one message)
        assert ros.spin_until(lambda: any(stamp_of(m) == ahead for m in s.joints.messages), TIMEOUT)
        before = clock.now().nanoseconds
        status = s.send('command', joint_state(['crank'], [0.9]))
        assert status.level == OK, status.message
        want = FourBar.joints(0.9)

        def answered():  # (a republication of the pose before may come first)
            return [
                m
                for m in s.joints.messages
                if max(abs(math.remainder(a - b, math.tau)) for a, b in zip(m.position, want))
                < 1e-9
            ]

        assert ros.spin_until(lambda: bool(answered()), TIMEOUT)
        answer = answered()[0]
        got = answer.header.stamp.sec * 10**9 + answer.header.stamp.nanosec
        assert before <= got <= clock.now().nanoseconds, (ahead, got)  # now, not ahead
        assert_close_angles(answer.position, FourBar.joints(0.9))
        # republication goes on, stamped now, holding the zero-stamped answer's pose
        assert ros.spin_until(lambda: len(s.joints) >= 3, TIMEOUT), 'republication stopped'
        later = s.joints.messages[-1]
        assert stamp_of(later) > stamp_of(answer)
        assert later.header.stamp.sec < ahead[0]
        assert_close_angles(later.position, FourBar.joints(0.9))


def test_a_client_clock_a_little_ahead_is_followed_so_the_newest_pose_is_newest(ros, serve):
    """Clock skew between machines: a command stamped 2 s ahead, then a zero-stamped one. The
    zero-stamped answer comes 1 ns after the client's stamp, so the newest pose keeps the newest
    stamp for tf (stamped now, it was older than the pose before it: an outside adversary, on
    the first version of the fix above)."""
    s = serve(scene='four_bar', publish_rate=0.0)
    now = s.node.get_clock().now().nanoseconds
    ahead = (now // 10**9 + 2, now % 10**9)
    s.good('command', joint_state(['crank'], [1.2], ahead))
    status = s.send('command', joint_state(['crank'], [0.9]))
    assert status.level == OK, status.message
    assert ros.spin_until(lambda: len(s.joints) >= 1, TIMEOUT)
    answer = s.joints.messages[0]
    assert_close_angles(answer.position, FourBar.joints(0.9))
    assert stamp_of(answer) == (ahead[0], ahead[1] + 1) or (
        ahead[1] == 999_999_999 and stamp_of(answer) == (ahead[0] + 1, 0)
    )


def test_republication_goes_on_while_a_client_clock_a_little_ahead_is_followed(ros, serve):
    """A command stamped 3 s ahead (skew the node follows): joint_states then went silent for
    3 s, the republication waiting for the clock to pass the client's stamp (an outside
    integrator: robot_state_publisher saw a 3 s gap). It goes on at publish_rate, each 1 ns
    after the last stamp sent, holding the commanded pose."""
    s = serve(scene='four_bar', publish_rate=20.0)
    now = s.node.get_clock().now().nanoseconds
    ahead = (now // 10**9 + 3, now % 10**9)
    s.good('command', joint_state(['crank'], [1.2], ahead))
    s.joints.clear()
    t0 = s.node.get_clock().now().nanoseconds
    assert ros.spin_until(lambda: len(s.joints) >= 6, 1.5), (
        f'{len(s.joints)} joint_states in 1.5 s at publish_rate 20'
    )
    assert s.node.get_clock().now().nanoseconds - t0 < 3 * 10**9  # (before the clock got there)
    stamps = [stamp_of(m) for m in s.joints.messages]
    assert all(b > a for a, b in zip(stamps, stamps[1:])), stamps
    assert stamps[0] > ahead, (stamps[0], ahead)
    for m in s.joints.messages:
        assert_close_angles(m.position, FourBar.joints(1.2))
