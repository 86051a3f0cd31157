"""`linkage record`, `linkage echo` and `linkage param` against a running node over real DDS
(the wheels-only equivalents of ros2 bag record / topic echo / param): what they record,
print and set is what the node published or holds, and a recorded bag is analysed by
`linkage bag` as the node answered it."""

from __future__ import annotations

import csv
import json
import math
import signal
import subprocess
import sys
import time

import pytest
from diagnostic_msgs.msg import DiagnosticStatus
from ros_harness import NodeProcess, RosHarness, random_domain_id, ros_env
from scenes import CONFIG
from sensor_msgs.msg import JointState

DOMAIN_ID = random_domain_id()
CRANKS = [0.3, 0.9, 1.5, 2.1]  # rad: the four_bar's crank turns fully


@pytest.fixture(scope='module')
def ros():
    harness = RosHarness(DOMAIN_ID)
    yield harness
    harness.close()


@pytest.fixture(scope='module')
def node(ros, tmp_path_factory):
    proc = NodeProcess(
        tmp_path_factory.mktemp('tools') / 'node',
        DOMAIN_ID,
        {'scene': str(CONFIG / 'four_bar.yaml')},
    ).start()
    end = time.monotonic() + 30
    while 'listening on' not in proc.output() and proc.alive() and time.monotonic() < end:
        time.sleep(0.05)
    assert 'listening on' in proc.output(), proc.output()
    yield proc
    assert proc.stop(signal.SIGINT) == 0, proc.output()[-3000:]


def linkage(*args, timeout=60):
    return subprocess.run(
        [sys.executable, '-m', 'linkage_ros.cli', *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=ros_env(DOMAIN_ID),
    )


def start_linkage(log, *args):
    """A linkage command left running, its stderr in ``log``, in its own process group."""
    sink = open(log, 'wb')  # noqa: SIM115 (lives with the process)
    return subprocess.Popen(
        [sys.executable, '-m', 'linkage_ros.cli', *args],
        stdout=sink,
        stderr=sink,
        env=ros_env(DOMAIN_ID),
        start_new_session=True,
    ), sink


def wait_subscribers(ros, topic, count, timeout=30.0):
    assert ros.spin_until(lambda: ros.node.count_subscribers(topic) >= count, timeout), topic


def send_commands(ros, node, values, pub=None):
    """Command each crank value (on ``pub``, or a publisher of its own) and wait for its ok
    status."""
    own = pub is None
    pub = pub or ros.publisher(JointState, node.topic('~/command'))
    ros.wait_for_discovery([pub], process=node)
    status = ros.collector(DiagnosticStatus, node.topic('~/status'))
    ros.wait_for_discovery(collectors=[status], process=node)
    for k, v in enumerate(values):
        msg = JointState(name=['crank'], position=[v])
        msg.header.stamp.sec = 100
        ros.publish(pub, msg)
        assert ros.spin_until(lambda k=k: len(status) > k, 20, node), 'no answer'
        assert status.last.message == 'ok', status.last.message
    ros.node.destroy_subscription(status.sub)
    if own:
        ros.node.destroy_publisher(pub)


def test_record_then_bag_analysis_matches_the_node(ros, node, tmp_path):
    bag = tmp_path / 'run'
    command, joints = node.topic('~/command'), node.topic('joint_states')
    log = tmp_path / 'record.log'
    # the commands' publisher exists first: the recorder finds the topic's type from it
    pub = ros.publisher(JointState, command)
    assert ros.spin_until(lambda: pub.get_subscription_count() >= 1, 30, node)
    rec, sink = start_linkage(log, 'record', command, joints, node.topic('~/status'), '-o', bag)
    try:
        # the recorder's reader side matched every writer (the writer side may see the match
        # first: a sample sent then would not reach it)
        for topic in (command, joints, node.topic('~/status')):
            assert ros.spin_until(
                lambda t=topic: f'{t}: 1 publisher(s) matched' in log.read_text(), 30, node
            ), log.read_text()
        send_commands(ros, node, CRANKS, pub=pub)
        # the recorder reads the same answers the harness just got; a quiet second lets the
        # last of them arrive there too before Ctrl-C (nothing observable says they have)
        ros.spin_for(1.0)
    finally:
        rec.send_signal(signal.SIGINT)
        code = rec.wait(timeout=30)
        sink.close()
    text = log.read_text()
    assert code == 0, text
    assert f'-> {bag}' in text and not (tmp_path / f'.{bag.name}.{rec.pid}.partial').exists()

    from rosbags.highlevel import AnyReader

    with AnyReader([bag]) as reader:
        got: dict[str, list] = {}
        for conn, _, raw in reader.messages():
            got.setdefault(conn.topic, []).append(reader.deserialize(raw, conn.msgtype))
    assert [m.position[0] for m in got[command]] == CRANKS
    answers = [m for m in got[joints] if m.header.stamp.sec == 100]  # the commands' stamp
    assert len(answers) == len(CRANKS)
    for want, js in zip(CRANKS, answers):
        # joint O2 = crank angle - ground angle (0 in four_bar.yaml): docs/SCENES.md
        position = dict(zip(js.name, js.position))
        assert math.remainder(position['O2'] - want, 2 * math.pi) == pytest.approx(0, abs=1e-12)

    out = tmp_path / 'solved.csv'
    analysed = linkage(
        'bag', str(bag), '--scene', 'four_bar', '--command-topic', command, '--out', str(out)
    )
    assert analysed.returncode == 0, analysed.stderr
    with open(out, newline='') as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == len(CRANKS)
    for row, js in zip(rows, answers):  # the offline answer is the node's
        for name, value in zip(js.name, js.position):
            assert float(row[f'joint.{name}']) == pytest.approx(value, abs=1e-12), name


def test_record_refuses_an_existing_bag_and_a_topic_without_publisher(tmp_path):
    (tmp_path / 'bag').mkdir()
    proc = linkage('record', '/joint_states', '-o', str(tmp_path / 'bag'), '--wait', '0.1')
    assert proc.returncode == 2 and 'exists' in proc.stderr, proc.stderr
    proc = linkage('record', '/nobody_publishes_this', '-o', str(tmp_path / 'b2'), '--wait', '1')
    assert proc.returncode == 2 and '/nobody_publishes_this' in proc.stderr, proc.stderr
    assert not (tmp_path / 'b2').exists()
    # a wait beyond discovery's moment is said at once (a misspelt name was 10 s of silence)
    proc = linkage('record', '/nobody_publishes_this', '-o', str(tmp_path / 'b3'), '--wait', '3')
    first, *_ = proc.stderr.splitlines()
    assert first == (
        'waiting for /nobody_publishes_this to appear in the ROS graph (up to 3 s: --wait)'
    ), proc.stderr


def test_echo_prints_the_answer_with_its_level_as_a_number(ros, node, tmp_path):
    log = tmp_path / 'echo.log'
    echo, sink = start_linkage(log, 'echo', node.topic('~/status'), '--count', '1', '--json')
    try:
        wait_subscribers(ros, node.topic('~/status'), 1)
        send_commands(ros, node, [1.0])
        code = echo.wait(timeout=30)
    finally:
        if echo.poll() is None:
            echo.kill()
        sink.close()
    assert code == 0, log.read_text()
    # (stderr shares the log: a discovery slower than WAIT_TOLD_S is said there first)
    (line,) = [ln for ln in log.read_text().splitlines() if not ln.startswith('waiting for ')]
    status = json.loads(line)
    assert status['level'] == 0 and status['message'] == 'ok'
    assert {kv['key']: kv['value'] for kv in status['values']}['request'] == 'command'


def test_param_get_and_set_go_through_the_node_checks(node):
    name = node.topic('~/')[:-1].rstrip('/')  # /<ns>/linkage_node
    done = linkage('param', 'set', name, 'demo_rate', '5')  # an integer where a double is meant
    assert done.returncode == 0, done.stderr
    got = linkage('param', 'get', name, 'demo_rate')
    assert got.returncode == 0 and float(got.stdout) == 5.0, got.stdout + got.stderr
    # 1e1 and 1.0e1 are numbers (YAML 1.1 reads them as text: they were refused as not a number)
    done = linkage('param', 'set', name, 'demo_rate', '1.0e1')
    assert done.returncode == 0, done.stdout + done.stderr
    assert float(linkage('param', 'get', name, 'demo_rate').stdout) == 10.0
    done = linkage('param', 'set', name, 'demo_rate', '5')
    refused = linkage('param', 'set', name, 'demo_rate', '-3')
    assert refused.returncode == 1 and 'demo_rate' in refused.stdout, refused.stdout
    assert float(linkage('param', 'get', name, 'demo_rate').stdout) == 5.0  # nothing changed
    # what YAML reads as no parameter type (`-`: [None], a date, a mapping, a mixed list) goes
    # as its text, as `ros2 param set` sends it: the node's refusal, where it was a traceback
    for text in ('-', '[1, a]', '{a: 1}', '2026-01-01'):
        odd = linkage('param', 'set', name, 'demo_rate', text)
        assert odd.returncode == 1 and 'Traceback' not in odd.stderr, odd.stderr
        assert 'refused demo_rate' in odd.stdout and f"(got '{text}')" in odd.stdout, odd.stdout
    assert float(linkage('param', 'get', name, 'demo_rate').stdout) == 5.0
    unknown = linkage('param', 'get', name, 'no_such_parameter')
    assert unknown.returncode == 2 and 'no_such_parameter' in unknown.stderr
    # a misspelt node: the wait said at once, the nodes seen named
    nobody = linkage('param', 'get', name + 'x', 'demo_rate', '--wait', '3')
    assert nobody.returncode == 2
    assert f'waiting for node {name}x (up to 3 s: --wait)' in nobody.stderr, nobody.stderr
    assert 'answered within 3 s (nodes seen: ' in nobody.stderr and name in nobody.stderr
    # a misspelt name to set: said as for get (rclpy's words were 'undeclared parameter(s): []')
    typo = linkage('param', 'set', name, 'demo_ratee', '5')
    assert typo.returncode == 2, typo.stdout + typo.stderr
    assert "has no parameter 'demo_ratee'" in typo.stderr, typo.stderr
    listed = linkage('param', 'list', name)
    assert 'demo_rate' in listed.stdout.split() and 'scene' in listed.stdout.split()


@pytest.mark.parametrize('param', ['actuated', 'dimensions', 'target_point_hold'])
def test_param_get_answers_an_empty_string_array_with_its_default(node, param):
    """The string arrays not given at start-up read as their documented default [] (TOPICS.md):
    declared by their type alone they had no value, and `param get` (as ros2 param get) said
    the node had no such parameter. They stay read-only."""
    name = node.topic('~/')[:-1].rstrip('/')
    got = linkage('param', 'get', name, param)
    assert got.returncode == 0, got.stdout + got.stderr
    assert got.stdout.strip() == '[]', got.stdout
    refused = linkage('param', 'set', name, param, '[x]')
    assert refused.returncode != 0, refused.stdout + refused.stderr
    assert 'read-only' in refused.stdout + refused.stderr, refused.stdout + refused.stderr
    assert linkage('param', 'get', name, param).stdout.strip() == '[]'
