"""``linkage_node``'s start-up and parameters: the demo sweep without commands, a bad scene or
parameter stopping start-up, the start-up log, the example parameter file, and the QoS the
parameters give every topic (history depths, which subscriptions carry QoS-event handlers)."""

from __future__ import annotations

import math
import signal
import time

import pytest
import yaml
from node_helpers import QUIET, SETTLE, finish, stamp_of
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from ros_harness import NodeProcess, random_domain_id
from scenes import CONFIG
from sensor_msgs.msg import JointState

from linkage_ros.core.model import Scene
from linkage_ros.node import NODE_NAME, PARAMETERS, ConfigError, make_config

DOMAIN_ID = random_domain_id()


# ---- demo sweep, start-up errors, parameters ------------------------------------------------


def test_demo_sweep_publishes_without_commands(ros, workdir):
    """The packaged default scene (no scene parameter) with demo_sweep: joint states flow."""
    proc = NodeProcess(workdir / 'demo', DOMAIN_ID, {'demo_sweep': True, 'demo_rate': 25.0}).start()
    try:
        joints = ros.collector(JointState, proc.topic('joint_states'))
        ros.wait_for_discovery(collectors=[joints], process=proc)
        assert ros.spin_until(lambda: len(joints) >= 6, 15.0, proc), len(joints)
        msgs = list(joints.messages)
        assert all(stamp_of(m) != (0, 0) for m in msgs)
        first = [m.position[0] for m in msgs]
        assert len(set(first)) == len(first), 'the sweep moves the first joint every tick'
        assert all(len(m.name) == len(m.position) >= 1 for m in msgs)
        # the terminal shows compact joint lines
        assert ros.spin_until(lambda: ' | ' in proc.output(), 5.0, proc)
        # demo_sweep can be switched off at runtime; read-only parameters cannot change
        client = AsyncParameterClient(ros.node, f'{proc.namespace}/{NODE_NAME}')
        assert client.wait_for_services(timeout_sec=10.0)
        future = client.set_parameters(
            [Parameter('demo_sweep', value=False), Parameter('tolerance', value=1e-9)]
        )
        assert ros.spin_until(future.done, 10.0, proc)
        ok, read_only = future.result().results
        assert ok.successful and not read_only.successful
        ros.spin_for(SETTLE)
        joints.clear()
        ros.spin_for(3 * 1 / 25.0 + QUIET)
        assert len(joints) == 0, 'the sweep stops when demo_sweep is set false'
    finally:
        code = proc.stop(signal.SIGINT)
    assert code == 0, proc.output()[-3000:]
    assert 'Traceback' not in proc.output()


# case: (scene file text, or None for a missing file, or '' for the default scene; parameters;
#        what stderr must name)
BAD_STARTS = {
    'bad_scene_value': (
        'four_bar:\n  ground: 0.3\n  crank: -0.1\n  coupler: 0.25\n  rocker: 0.2\n',
        {},
        ['four_bar.crank', '-0.1'],
    ),
    'bad_scene_key': (
        'four_bar:\n  ground: 0.3\n  crank: 0.1\n  coupler: 0.25\n  rocker: 0.2\n  rockr: 0.2\n',
        {},
        ['four_bar.rockr', 'unknown key'],
    ),
    'bad_yaml': ('four_bar: {ground: 0.3\n', {}, ['invalid YAML']),
    'missing_scene': (None, {}, ['no_such_scene.yaml']),
    'bad_tolerance': ('', {'tolerance': -1.0}, ['tolerance', '-1.0']),
    'bad_solver': ('', {'solver': 'fastest'}, ['solver', 'fastest']),
    'bad_queue_depth': ('', {'queue_depth': 0}, ['queue_depth', '0']),
    'demo_of_a_structure': (
        'name: truss\npoints: {O1: [0, 0], O2: [0.4, 0], P: [0.15, 0.2]}\n'
        'links: {ground: [O1, O2], left: [O1, P], right: [O2, P]}\n',
        {'demo_sweep': True},
        ['demo_sweep', 'no actuator to sweep', '0 DOF'],
    ),
}


@pytest.mark.parametrize('case', list(BAD_STARTS))
def test_bad_scene_or_parameter_stops_startup(workdir, case):
    text, params, fragments = BAD_STARTS[case]
    d = workdir / f'start_{case}'
    params = dict(params)
    if text is None:
        params['scene'] = str(d / 'no_such_scene.yaml')
    elif text:
        d.mkdir()
        scene = d / 'scene.yaml'
        scene.write_text(text)
        params['scene'] = str(scene)
        fragments = fragments + [str(scene)]
    proc = NodeProcess(d, DOMAIN_ID, params).start()
    try:
        code = proc.wait(timeout=30)
    finally:
        proc.stop()
    err = proc.stderr()
    assert code != 0
    for f in fragments:
        assert f in err, err
    assert 'Traceback' not in err, err
    assert len(err.strip().splitlines()) <= 3, err


def test_startup_log_names_the_queue_depth_and_ignored_parameters(workdir):
    """A parameter the node does not have (a misspelling) is named in a warning, not silently
    dropped; the start-up line shows the queue depth in force."""
    proc = NodeProcess(
        workdir / 'misspelt', DOMAIN_ID, {'queue_depth': 33, 'output_depth': 44, 'queue_dept': 100}
    ).start()
    try:
        t_end = time.monotonic() + 30
        while 'listening on' not in proc.output() and proc.alive() and time.monotonic() < t_end:
            time.sleep(0.05)
        out = proc.output()
        assert 'listening on' in out, out
        assert '(reliable, keep last 44; commands keep last 33)' in out, out
        (warn,) = [ln for ln in out.splitlines() if 'ignoring parameter' in ln]
        assert 'WARN' in warn and "['queue_dept']" in warn and 'queue_depth' in warn, warn
    finally:
        finish(proc)


def test_parameter_file_example_is_valid():
    data = yaml.safe_load((CONFIG / 'params' / 'linkage_node.yaml').read_text())
    params = data['linkage_node']['ros__parameters']
    assert set(params) <= {p.name for p in PARAMETERS}
    config = make_config(params)
    assert Scene.from_yaml(config.scene_path).mechanism.dof >= 1
    with pytest.raises(ConfigError, match='max_iterations'):
        make_config(dict(params, max_iterations=0))
    with pytest.raises(ConfigError, match='branch'):
        make_config(dict(params, branch='sideways'))
    assert make_config(params).queue_depth == 10
    assert make_config(params).output_depth == 100
    for bad in (0, 2.5, '100'):
        with pytest.raises(ConfigError, match=f"'output_depth'.*{bad!r}"):
            make_config(dict(params, output_depth=bad))
    assert make_config(dict(params, queue_depth=250)).queue_depth == 250
    for bad in (0, -5, 2.5, True, '100'):
        with pytest.raises(ConfigError, match=f"'queue_depth'.*{bad!r}"):
            make_config(dict(params, queue_depth=bad))
    assert make_config(params).executor == 'events'
    assert make_config(dict(params, executor='single_threaded')).executor == 'single_threaded'
    with pytest.raises(ConfigError, match="'executor'.*multi"):
        make_config(dict(params, executor='multi'))
    for name in ('publish_rate', 'marker_rate'):
        assert getattr(make_config(dict(params, **{name: 0.0})), name) == 0.0  # 0 = off
        assert getattr(make_config(dict(params, **{name: 250.0})), name) == 250.0
        for bad in (-1.0, 1e-4, 5000.0, math.nan, True, '10'):
            with pytest.raises(ConfigError, match=f"'{name}'.*must be 0 \\(off\\)"):
                make_config(dict(params, **{name: bad}))


def test_queue_depth_sets_the_history_of_every_topic(ros):
    """queue_depth is the keep-last depth of every subscription and of ~/solved_trajectory,
    output_depth that of joint_states, ~/points/<p> and ~/status (reliable, volatile); ~/markers
    is latched (depth 1) and /diagnostics the standard topic. Defaults 10 and 100."""
    answers = ('/joint_states', '/status') + tuple(f'/points/{p}' for p in 'LKJ')
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from linkage_ros.node import LinkageNode

    for depth, out_depth, overrides in (
        (10, 100, [Parameter('scene', value='excavator')]),
        (
            250,
            7,
            [
                Parameter('scene', value='excavator'),
                Parameter('queue_depth', Parameter.Type.INTEGER, 250),
                Parameter('output_depth', Parameter.Type.INTEGER, 7),
            ],
        ),
    ):
        node = LinkageNode(context=ros.context, parameter_overrides=overrides)
        try:
            ours = [
                e
                for e in list(node.publishers) + list(node.subscriptions)
                if 'parameter_events' not in e.topic_name
                and not e.topic_name.endswith(('/markers', '/diagnostics'))
            ]
            assert len(ours) >= 3 + 2 + 3  # outputs, command and target, 3 points
            assert len([e for e in ours if e.topic_name.endswith(answers)]) == 5
            for e in ours:
                q = e.qos_profile
                assert (q.depth, q.history, q.reliability, q.durability) == (
                    out_depth if e.topic_name.endswith(answers) else depth,
                    HistoryPolicy.KEEP_LAST,
                    ReliabilityPolicy.RELIABLE,
                    DurabilityPolicy.VOLATILE,
                ), e.topic_name
            # markers are latched (the latest for a late RViz); /diagnostics is the standard topic
            (markers,) = [p for p in node.publishers if p.topic_name.endswith('/markers')]
            q = markers.qos_profile
            assert (q.depth, q.durability) == (1, DurabilityPolicy.TRANSIENT_LOCAL)
            (diag,) = [p for p in node.publishers if p.topic_name == '/diagnostics']
            assert diag.qos_profile.reliability == ReliabilityPolicy.RELIABLE
        finally:
            node.destroy_node()


def test_only_command_and_target_carry_qos_event_handlers(ros):
    """Each QoS-event handler is a waitable the executor polls on every message: outputs and
    per-point targets carry none, ~/command and ~/target keep rclpy's incompatibility warnings."""
    from linkage_ros.node import LinkageNode

    node = LinkageNode(
        context=ros.context,
        parameter_overrides=[Parameter('scene', Parameter.Type.STRING, 'four_bar')],
    )
    try:
        ours = [p for p in node.publishers if 'parameter_events' not in p.topic_name]
        assert {p.topic_name.rsplit('/', 1)[-1] for p in ours} >= {
            'joint_states',
            'markers',
            'status',
            'P',
        }
        assert all(p.event_handlers == [] for p in ours)
        handled = {s.topic_name.rsplit('/', 1)[-1] for s in node.subscriptions if s.event_handlers}
        assert handled == {'command', 'target'}
        assert sum(1 for s in node.subscriptions if 'target_point' in s.topic_name) == 3
    finally:
        node.destroy_node()
