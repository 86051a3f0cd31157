"""Adversarial tests of ``linkage_node``'s parameters: runtime changes that cannot apply are
refused with a reason (in this process and on a subprocess node, which then still answers and
exits cleanly), a failing demo turns demo_sweep off, and the checks of parameter values and
types (whole numbers for doubles, the demo_rate range, frame_id, prefix, use_sim_time).

The in-process node is adversary_helpers.Served, over real DDS on this module's random domain.
"""

from __future__ import annotations

import math
import re
import signal

import pytest
from adversary_helpers import (
    ERROR,
    OK,
    TIMEOUT,
    FourBar,
    assert_close_angles,
    joint_state,
    stamp_of,
)
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from ros_harness import NodeProcess, random_domain_id
from sensor_msgs.msg import JointState

from linkage_ros.core.solver import Result
from linkage_ros.node import (
    DEMO_RATE_MAX,
    DEMO_RATE_MIN,
    NODE_NAME,
    ConfigError,
    LinkageNode,
    make_config,
)

DOMAIN_ID = random_domain_id()
HARNESS_NAME = 'linkage_adversary'


# ---- runtime parameters ---------------------------------------------------------------------


def _set(ros, client, *params):
    future = client.set_parameters(list(params))
    assert ros.spin_until(future.done, TIMEOUT)
    return future.result().results


def test_runtime_parameter_changes_that_cannot_apply_are_refused(ros, serve):
    """`ros2 param set demo_rate 1e-12` used to pass the check (> 0) and then raise inside the
    parameter callback (a timer period rclpy cannot hold): the exception left the executor and
    killed the node. 1e300 Hz gave a 0 ns timer, a busy loop. Now every bad value (and type,
    read-only or unknown name) is refused with a reason, and the demo keeps its rate."""
    s = serve(scene='four_bar', demo_sweep=True, demo_rate=50.0)
    client = AsyncParameterClient(ros.node, f'{s.ns}/{NODE_NAME}')
    assert client.wait_for_services(timeout_sec=TIMEOUT)
    timer = s.node.demo.timer
    for value in (
        1e-12,
        1e-300,
        1e300,
        DEMO_RATE_MAX * 1.001,
        DEMO_RATE_MIN / 2,
        0.0,
        -1.0,
        math.nan,
        math.inf,
    ):
        (r,) = _set(ros, client, Parameter('demo_rate', value=value))
        assert not r.successful and "'demo_rate'" in r.reason and repr(value) in r.reason, (
            value,
            r.reason,
        )
        assert s.node.get_parameter('demo_rate').value == 50.0
        assert s.node.config.demo_rate == 50.0 and s.node.demo.timer is timer
    for param, fragment in (
        (Parameter('demo_rate', value='5'), "'demo_rate'"),
        (Parameter('demo_sweep', value='yes'), 'BOOL'),
        (Parameter('tolerance', value=1e-9), 'read-only'),
        (Parameter('scene', value='excavator'), 'read-only'),
    ):
        (r,) = _set(ros, client, param)
        assert not r.successful and fragment in r.reason, r.reason
    assert not _set(ros, client, Parameter('queue_dept', value=3))[0].successful
    # the sweep still runs at 50 Hz: its answers keep coming and they are whole and finite
    s.clear()
    assert ros.spin_until(lambda: len(s.joints) >= 3, TIMEOUT)
    assert all(
        len(j.position) == 4 and all(map(math.isfinite, j.position)) for j in s.joints.messages
    )
    # the range ends are accepted
    for value in (DEMO_RATE_MAX, DEMO_RATE_MIN, 40.0, 25):  # 25: a whole number is a double
        (r,) = _set(ros, client, Parameter('demo_rate', value=value))
        assert r.successful, r.reason
        assert abs(s.node.demo.timer.timer_period_ns - 1e9 / value) <= 1
    assert s.node.config.demo_rate == 25.0 and isinstance(s.node.config.demo_rate, float)
    (r,) = _set(ros, client, Parameter('demo_sweep', value=False))
    assert r.successful and s.node.demo.timer is None


def test_a_demo_that_stops_turns_demo_sweep_off_and_can_be_restarted(ros, serve, tmp_path):
    """After three failed ticks the sweep stops. demo_sweep used to stay true, so setting it true
    again changed nothing and the sweep could not be restarted without first setting false."""
    s = serve(scene='four_bar', demo_rate=200.0)
    # no command assembles (a scene cannot be drawn so: its reference pose must be within its
    # limits and assemble), so every tick of the sweep fails
    s.node.engine.command = lambda values, rates=None: Result(
        False, 'cannot assemble: forced by the test'
    )
    client = AsyncParameterClient(ros.node, f'{s.ns}/{NODE_NAME}')
    assert client.wait_for_services(timeout_sec=TIMEOUT)
    for _ in range(2):
        s.clear()
        (r,) = _set(ros, client, Parameter('demo_sweep', value=True))  # restart: it runs
        assert r.successful, r.reason
        assert ros.spin_until(
            lambda: not s.node.get_parameter('demo_sweep').value and len(s.status) >= 3, TIMEOUT
        )
        assert s.node.demo.timer is None and not s.node.config.demo_sweep
        assert [st.level for st in s.status.messages] == [ERROR] * 3  # then it stopped
        assert 'cannot assemble' in s.status.last.message
        assert len(s.joints) == 0


def test_make_config_checks_demo_rate_frame_id_and_queue_depth():
    for rate in (1e-12, 1e300, DEMO_RATE_MAX + 1, 0.0, math.nan, math.inf, True, '5'):
        with pytest.raises(ConfigError, match="'demo_rate'"):
            make_config({'demo_rate': rate})
    for rate in (DEMO_RATE_MIN, 1.0, DEMO_RATE_MAX):
        assert make_config({'demo_rate': rate}).demo_rate == rate
    for frame in ('/base_link', 'base link', 'base_link ', 'a\tb', '\n'):
        with pytest.raises(ConfigError, match="'frame_id'"):
            make_config({'frame_id': frame})
    for frame in ('', 'base_link', 'robot1/base_link', 'map'):
        assert make_config({'frame_id': frame}).frame_id == frame
    for depth in (2**31, 2**63 - 1):
        with pytest.raises(ConfigError, match=f"'queue_depth'.*{depth}"):
            make_config({'queue_depth': depth})
    assert make_config({'queue_depth': 2**31 - 1}).queue_depth == 2**31 - 1
    # a tolerance of a whole length scale answered a press's slider target OK 0.17 m from it
    # (a Newton solve stops at its first iterate): refused, naming the parameter (it was
    # blamed on 'solver' when the solver refused it)
    for tol in (1, 0.01):
        with pytest.raises(ConfigError, match=r"'tolerance': must be at most 0\.001"):
            make_config({'tolerance': tol})
    assert make_config({'tolerance': 1e-3}).tolerance == 1e-3


def test_whole_numbers_are_taken_for_doubles(ros):
    """ROS users write `-p publish_rate:=0` (TOPICS.md's own "0 = answers only"): a whole
    number is a double's value, converted; the node starts with it."""
    node = LinkageNode(
        context=ros.context,
        parameter_overrides=[
            Parameter('publish_rate', value=0),
            Parameter('marker_rate', value=0),
            Parameter('demo_rate', value=5),
        ],
    )
    try:
        cfg = node.config
        assert (cfg.publish_rate, cfg.marker_rate, cfg.demo_rate) == (0.0, 0.0, 5.0)
        assert isinstance(cfg.demo_rate, float)
    finally:
        node.destroy_node()


def test_wrong_parameter_type_message(ros):
    for name, value, fragment in (
        ('queue_depth', '10', 'must be an integer'),
        ('demo_rate', '20', 'must be a number (a double or a whole number'),
        ('demo_sweep', 'yes', 'must be a bool'),
        ('frame_id', 5, 'must be a string'),
    ):
        with pytest.raises(ConfigError, match=rf"'{name}': {re.escape(fragment)}"):
            LinkageNode(context=ros.context, parameter_overrides=[Parameter(name, value=value)])


def test_demo_rate_parameter_descriptor_shows_the_range(ros):
    node = LinkageNode(context=ros.context)
    try:
        desc = node.describe_parameter('demo_rate')
        assert f'{DEMO_RATE_MIN:g}' in desc.additional_constraints
        assert f'{DEMO_RATE_MAX:g}' in desc.additional_constraints
    finally:
        node.destroy_node()


def test_node_survives_everything_and_exits_cleanly(ros, tmp_path):
    """A subprocess node (the real entry point) after refused parameter changes, with the sweep
    on and off: still answering, then a clean exit 0 on SIGINT, no traceback."""
    proc = NodeProcess(
        tmp_path / 'sub', DOMAIN_ID, {'scene': 'four_bar', 'demo_rate': 10.0, 'queue_dept': 3}
    )  # misspelt
    proc.start()
    try:
        cmd = ros.publisher(JointState, proc.topic('~/command'))
        status = ros.collector(DiagnosticStatus, proc.topic('~/status'))
        joints = ros.collector(JointState, proc.topic('joint_states'))
        ros.wait_for_discovery([cmd], [status, joints], process=proc)
        client = AsyncParameterClient(ros.node, f'{proc.namespace}/{NODE_NAME}')
        assert client.wait_for_services(timeout_sec=30.0)
        for value in (1e-12, 1e300):
            (r,) = _set(ros, client, Parameter('demo_rate', value=value))
            assert not r.successful
        (r,) = _set(ros, client, Parameter('demo_sweep', value=True))
        assert r.successful
        (r,) = _set(ros, client, Parameter('demo_rate', value=1e-12))  # with the sweep on
        assert not r.successful and 'demo_rate' in r.reason
        (r,) = _set(ros, client, Parameter('demo_sweep', value=False))
        assert r.successful
        # writers of the node may match our readers a little after our writer matched its
        # reader: resend a good command until one is answered
        stamp = (424242, 1)
        good = joint_state(['crank'], [1.0], stamp)
        for _ in range(10):
            ros.publish(cmd, good)
            if ros.spin_until(
                lambda: any(stamp_of(j) == stamp for j in joints.messages), 3.5, proc
            ):
                break
        js = next(j for j in joints.messages if stamp_of(j) == stamp)
        assert_close_angles(js.position, FourBar.joints(1.0))
        assert proc.alive()
    finally:
        code = proc.stop(signal.SIGINT)
    assert code == 0, proc.output()[-3000:]
    assert 'Traceback' not in proc.output(), proc.output()[-3000:]
    # 'listening on' is the last start-up line: one who waits for it (as test_node does) has
    # the start-up warnings already; the warning used to come after it (a race for readers)
    lines = proc.stderr().splitlines()
    warn = next(i for i, ln in enumerate(lines) if 'ignoring parameter(s)' in ln)
    ready = next(i for i, ln in enumerate(lines) if 'listening on' in ln)
    assert warn < ready and "['queue_dept']" in lines[warn]


def test_prefix_names_the_joints_and_hardware_id_the_scene(serve):
    """Two mechanisms on one /joint_states need distinct joint names: the prefix parameter is
    prepended to every published name (requests keep the scene's names); the status carries
    the scene as hardware_id."""
    s = serve(scene='four_bar', prefix='left_')
    msg = joint_state(['crank'], [0.9], (131, 0))
    status = s.send('command', msg)
    assert status.level == OK and status.hardware_id == 'four_bar'
    assert s.ros.spin_until(lambda: len(s.joints) >= 1, TIMEOUT)
    assert list(s.joints.last.name) == ['left_' + j for j in s.mech.joint_names]
    with pytest.raises(ConfigError, match="'prefix': must be a string without whitespace"):
        make_config({'prefix': 'left arm'})


def test_use_sim_time_cannot_be_switched_at_runtime(ros):
    """Switched at runtime it stopped every timer (republication, markers, /diagnostics)
    without a word: refused, naming the start-up way."""
    from rclpy.parameter import Parameter as RclpyParameter

    node = LinkageNode(context=ros.context)
    try:
        (r,) = node.set_parameters([RclpyParameter('use_sim_time', value=True)])
        assert not r.successful and 'only be set at start-up' in r.reason
        assert node.get_parameter('use_sim_time').value is False
    finally:
        node.destroy_node()
