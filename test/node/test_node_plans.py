"""Plans (``~/trajectory``; ``~/target_path/<p>`` goes the same way) beside commands: a
10^4-point plan is solved off the command path, plans beyond the worker's queue are dropped
for load with a status that says so, requests larger than the scene's bound are refused
unread, and a name with a NUL is refused as ``linkage bag`` refuses it.

The node runs in this process (adversary_helpers.Served: its own namespace, a random
domain, answers awaited, never slept for). Orderings and counts are asserted, not durations.
"""

from __future__ import annotations

import math

import pytest
from adversary_helpers import TIMEOUT, FourBar, Served, assert_close_angles, joint_state
from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.serialization import serialize_message
from ros_harness import RosHarness, random_domain_id
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.node import NODE_NAME
from linkage_ros.plan_worker import PLAN_QUEUE
from linkage_ros.trajectory import answer_trajectory_msg

OK, ERROR = DiagnosticStatus.OK, DiagnosticStatus.ERROR


@pytest.fixture(scope='module')
def ros():
    harness = RosHarness(random_domain_id(), name='linkage_plans')
    yield harness
    harness.close()


@pytest.fixture
def four_bar(ros):
    served = Served(ros, {'scene': 'four_bar'})
    yield served
    served.close()


_stamp = iter(range(10_000, 10**9))


def crank_turns(n: int, start: float = 1.0) -> JointTrajectory:
    """``n`` points turning the four-bar's crank (a full turn per 360 points), 1 ms apart."""
    msg = JointTrajectory(joint_names=['crank'])
    msg.points = [
        JointTrajectoryPoint(
            positions=[start + 2 * math.pi * k / 360],
            time_from_start=Duration(sec=(k + 1) // 1000, nanosec=(k + 1) % 1000 * 1_000_000),
        )
        for k in range(n)
    ]
    return msg


def plan_statuses(served: Served, request: str = 'trajectory') -> list[DiagnosticStatus]:
    return [
        s
        for s in served.status.messages
        if {v.key: v.value for v in s.values}.get('request') == request
    ]


def solved_collector(served: Served):
    solved = served.ros.collector(JointTrajectory, f'{served.ns}/{NODE_NAME}/solved_trajectory')
    assert served.ros.spin_until(lambda: solved.sub.get_publisher_count() > 0, TIMEOUT)
    return solved


def test_commands_are_answered_while_a_large_trajectory_is_solved(ros, four_bar):
    """A 10^4-point trajectory used to hold the node's only thread for seconds: no command was
    answered until its status. Now commands sent one at a time after it are answered while it
    is solved (before its status), correctly, and the plan's answer is right too."""
    s = four_bar
    s.good('command', joint_state(['crank'], [0.4], (next(_stamp), 0)))
    solved = solved_collector(s)
    plan = crank_turns(10_000)
    s.clear()
    ros.publish(s.pub('trajectory', JointTrajectory), plan)
    command = s.pub('command')
    during, sent = 0, 0
    last_theta = None
    while not plan_statuses(s) and sent < 20_000:
        stamp = (next(_stamp), 0)
        last_theta = 0.5 + 0.001 * (sent % 500)
        command.publish(joint_state(['crank'], [last_theta], stamp))
        sent += 1
        assert ros.spin_until(
            lambda st=stamp: any(
                (j.header.stamp.sec, j.header.stamp.nanosec) == st for j in s.joints.messages
            ),
            TIMEOUT,
        ), 'a command beside the plan was not answered'
        if not plan_statuses(s):
            during += 1
            assert_close_angles(s.joints.last.position, FourBar.joints(last_theta))
    assert ros.spin_until(lambda: len(plan_statuses(s)) >= 1 and len(solved) >= 1, 120.0)
    status = plan_statuses(s)[0]
    assert status.level == OK, status.message
    assert during >= 20, f'only {during} commands answered while the plan was solved'
    points = solved.last.points
    assert len(points) == 10_000
    for k in (0, 1234, 9999):
        theta = 1.0 + 2 * math.pi * k / 360
        assert_close_angles(points[k].positions, FourBar.joints(theta))
    # the plan left the state as the commands made it
    assert_close_angles(s.joints.last.position, FourBar.joints(last_theta))


def test_plans_beyond_the_queue_are_dropped_for_load_with_one_status_each(ros, four_bar):
    s = four_bar
    s.good('command', joint_state(['crank'], [0.4], (next(_stamp), 0)))
    solved = solved_collector(s)
    pub = s.pub('trajectory', JointTrajectory)
    raw = serialize_message(crank_turns(3000))
    s.clear()
    sent = PLAN_QUEUE + 4
    for _ in range(sent):
        pub.publish(raw)
    assert ros.spin_until(lambda: len(plan_statuses(s)) >= sent, 120.0)
    ros.spin_for(0.3)
    statuses = plan_statuses(s)
    assert len(statuses) == sent
    dropped = [st for st in statuses if st.message.startswith('dropped for load')]
    solved_ok = [st for st in statuses if st.level == OK]
    assert dropped and all(st.level == ERROR for st in dropped)
    assert len(dropped) + len(solved_ok) == sent and len(solved) == len(solved_ok) >= 1


def test_requests_larger_than_the_scene_allows_are_refused_unread(ros, four_bar):
    """A ~/target or ~/trajectory longer than any request the scene can make is refused from
    its length, naming the bound; the next command is answered as usual."""
    s = four_bar
    big_name = 'x' * 50_000
    message = s.bad(
        'target',
        joint_state([big_name, 'crank'], [0.1, 0.2], (next(_stamp), 0)),
        ['JointState message is', 'bytes', 'is at most'],
        ('command', joint_state(['crank'], [0.7], (next(_stamp), 0))),
    )
    assert big_name not in message
    plan = crank_turns(3)
    plan.header.frame_id = 'f' * 7_000_000  # a trajectory bound: MBs for 10^4 points
    s.clear()
    ros.publish(s.pub('trajectory', JointTrajectory), plan)
    assert ros.spin_until(lambda: len(plan_statuses(s)) >= 1, TIMEOUT)
    status = plan_statuses(s)[0]
    assert status.level == ERROR and 'bytes; one to scene' in status.message, status.message
    assert 'f' * 100 not in status.message


def test_a_trajectory_name_with_a_nul_is_refused_as_the_bag_refuses_it(ros, four_bar):
    """rclpy read ``crank\\x00x`` as ``crank`` and the node solved it; the bag (rosbags reads
    strings whole) refuses it. Now the node reads it whole too: the same refusal."""
    from rosbags.typesys import Stores, get_typestore

    from linkage_ros.bag.plans import TRAJECTORY, decode_plan

    s = four_bar
    s.good('command', joint_state(['crank'], [0.4], (next(_stamp), 0)))
    msg = crank_turns(2)
    msg.joint_names = ['crankQx']
    raw = serialize_message(msg).replace(b'crankQx', b'crank\x00x')
    bag_msg = decode_plan(raw, TRAJECTORY, get_typestore(Stores.ROS2_JAZZY))
    assert list(bag_msg.joint_names) == ['crank\x00x']
    want, _ = answer_trajectory_msg(Engine(s.mech, EngineSettings()), bag_msg, s.node.frame_id)
    assert not want.success
    s.clear()
    ros.publish(s.pub('trajectory', JointTrajectory), raw)
    assert ros.spin_until(lambda: len(plan_statuses(s)) >= 1, TIMEOUT)
    status = plan_statuses(s)[0]
    assert status.level == ERROR and status.message == want.reason, status.message
    assert "'crank\\x00x'" in status.message
    assert isinstance(s.joints.messages, list) and len(s.joints) == 0


def test_a_plan_worker_that_dies_is_answered_for_and_replaced(ros, four_bar):
    """The worker process killed with a plan in hand: that plan gets one ERROR status saying
    so (not silence, not 'dropped for load' forever after), and the next plan is solved by a
    new worker."""
    import os
    import signal

    s = four_bar
    s.good('command', joint_state(['crank'], [0.4], (next(_stamp), 0)))
    solved = solved_collector(s)
    pub = s.pub('trajectory', JointTrajectory)
    s.clear()
    ros.publish(pub, crank_turns(10_000))
    worker = s.node.plans.worker
    assert ros.spin_until(lambda: worker.pending == 1 and worker.pid is not None, TIMEOUT)
    os.kill(worker.pid, signal.SIGKILL)
    assert ros.spin_until(lambda: len(plan_statuses(s)) >= 1, TIMEOUT)
    (status,) = plan_statuses(s)
    assert status.level == ERROR and 'the plan worker exited' in status.message, status.message
    s.clear()
    ros.publish(pub, crank_turns(20))
    assert ros.spin_until(lambda: len(plan_statuses(s)) >= 1 and len(solved) >= 1, 60.0)
    assert plan_statuses(s)[0].level == OK
    assert len(solved.last.points) == 20


def test_the_plan_worker_runs_from_start_up_on_idle_cpu_only(ros, four_bar):
    """The worker is started with the node (its interpreter start-up and imports are not paid
    beside the first plan's commands) and scheduled SCHED_IDLE, the scheduler's promise that
    it runs only on CPU time no other process wants (not nice 5, which still took a quarter of
    a contended core from the commands). Read from the kernel, not from the node's code."""
    import os

    worker = four_bar.node.plans.worker
    pid = worker.pid
    assert pid is not None and os.path.exists(f'/proc/{pid}'), 'no worker before any plan'
    if hasattr(os, 'SCHED_IDLE'):
        assert os.sched_getscheduler(pid) == os.SCHED_IDLE
    # and the threads it starts inherit it: every thread of the worker process
    for tid in os.listdir(f'/proc/{pid}/task'):
        with open(f'/proc/{pid}/task/{tid}/sched') as fh:
            policy = next(line for line in fh if line.startswith('policy'))
        assert int(policy.split(':')[1]) == getattr(os, 'SCHED_IDLE', 5), (tid, policy)
    # a plan is still solved (the machine has idle moments: the test waits for them)
    solved = solved_collector(four_bar)
    four_bar.clear()
    ros.publish(four_bar.pub('trajectory', JointTrajectory), crank_turns(50))
    assert ros.spin_until(lambda: len(plan_statuses(four_bar)) >= 1 and len(solved) >= 1, 120.0)
    assert plan_statuses(four_bar)[0].level == OK
    assert worker.pid == pid, 'the plan was not solved by the worker started with the node'
