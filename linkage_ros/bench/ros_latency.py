"""The node's command -> joint_states latency and loss-free rate against a bare rclpy relay."""

from __future__ import annotations

import json
import os
import random
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .all_outputs import bench_all_outputs
from .ros_driver import Driver, Link, Proc, relay_script, ros_env
from .settings import DEFAULT_DEPTH, FloodKind, Sizes, log

# =============================================================================================
# (c) node latency and loss-free rate vs a bare rclpy relay
# =============================================================================================


#: the flood measurement: commands at this rate beside hostile requests at their rate
FLOOD_COMMAND_HZ = 500.0
FLOOD_RATE_HZ = 100.0
#: (kind, the node's topic, requests per second): flood.KINDS
FLOODS = (
    (FloodKind.NEW_SETS, 'target', FLOOD_RATE_HZ),
    (FloodKind.HUGE, 'target', FLOOD_RATE_HZ),
    (FloodKind.TRAJECTORY, 'trajectory', 10.0),
)
#: the parts of the node measurement ``parts`` selects from
NODE_PARTS = ('rates', 'floods', 'all_outputs')


def sustained_rate(runs: list[dict]) -> float | None:
    """Highest commanded rate with zero loss whose achieved send rate is >= 95 % of it."""
    best = None
    for r in runs:
        if r['lost'] == 0 and r['achieved_rate'] and r['achieved_rate'] >= 0.95 * r['rate']:
            best = r['rate'] if best is None else max(best, r['rate'])
    return best


def bench_node(
    sizes: Sizes,
    include_node: bool = True,
    include_relay: bool = True,
    node_argv: Sequence[str] | None = None,
    parts: Sequence[str] = NODE_PARTS,
) -> dict:
    """The relay and the node run as separate processes under one driver: first a paired
    latency phase (ping-pong, targets taking turns), then each target alone at every rate
    ('rates'), the node beside floods of hostile requests ('floods'), and every output on
    ('all_outputs'). ``node_argv`` replaces the node's command line (e.g. to measure a patched
    node)."""
    try:
        import rclpy  # noqa: F401
        from sensor_msgs.msg import JointState  # noqa: F401
    except Exception as exc:  # noqa: BLE001
        return {'skipped': f'rclpy / sensor_msgs unavailable: {exc}'}
    domain = random.Random(os.getpid() ^ time.time_ns()).randint(1, 200)
    env = ros_env(domain)
    work = Path(tempfile.mkdtemp(prefix='linkage_bench_'))
    tag = f'lkb{os.getpid()}'
    out: dict[str, Any] = {
        'domain_id': domain,
        'rates': list(sizes.node_rates),
        'seconds_per_rate': sizes.node_seconds,
        'ping_pong_n': sizes.node_ping,
        'depth': DEFAULT_DEPTH,
        'deep_depth': sizes.node_deep_depth,
        'deep_rates': list(sizes.node_deep_rates),
        'targets': {},
        'logs': str(work),
        'parts': list(parts),
    }
    # (label, command line, command topic, answer topic, queue depth); the *_deep targets are
    # the same programs with the deeper queue, measured at node_deep_rates only
    deep = [('', DEFAULT_DEPTH)] + (
        [('_deep', sizes.node_deep_depth)] if sizes.node_deep_rates else []
    )
    specs = []
    specs_ns: dict[str, str] = {}
    if include_relay:
        script = relay_script()
        if script is None:
            out['targets']['relay'] = {'ok': False, 'reason': 'bench/relay_node.py not found'}
        else:
            for suffix, depth in deep:
                ns = f'/{tag}_relay{suffix}'
                specs.append(
                    (
                        f'relay{suffix}',
                        [
                            sys.executable,
                            str(script),
                            '--depth',
                            str(depth),
                            '--ros-args',
                            '-r',
                            f'__ns:={ns}',
                        ],
                        f'{ns}/relay_node/command',
                        f'{ns}/joint_states',
                        depth,
                    )
                )
    if include_node:
        argv = list(node_argv) if node_argv else [sys.executable, '-m', 'linkage_ros.node']
        for suffix, depth in deep:
            ns = f'/{tag}_node{suffix}'
            specs_ns[f'node{suffix}'] = ns
            specs.append(
                (
                    f'node{suffix}',
                    argv
                    + [
                        '--ros-args',
                        '-r',
                        f'__ns:={ns}',
                        '-p',
                        'scene:=four_bar',
                        '-p',
                        f'queue_depth:={depth}',
                    ],
                    f'{ns}/linkage_node/command',
                    f'{ns}/joint_states',
                    depth,
                )
            )
    # the command: the four-bar crank stepping through a full turn
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    try:
        driver = Driver(domain, ['crank'], lambda k: [1.0 + 0.0105 * (k % 600)])
    except Exception as exc:  # noqa: BLE001
        return {'skipped': f'cannot start an rclpy context: {exc}'}
    procs: dict[str, Proc] = {}
    links: dict[str, Link] = {}
    try:
        for label, argv, _cmd_topic, _out_topic, depth in specs:
            log(
                f'node benchmark: starting {label} ({" ".join(Path(a).name for a in argv[:3])}, '
                f'queue depth {depth}) on ROS domain {domain}'
            )
            procs[label] = Proc(argv, env, work, label)
        for label, _argv, cmd_topic, out_topic, depth in specs:
            link = driver.link(label, cmd_topic, out_topic)
            why = driver.connect(link, sizes.node_warmup)
            if why is None and not procs[label].alive():
                why = 'exited'
            if why is not None:
                if not procs[label].alive():
                    why += f'; {label} exited: {procs[label].tail()}'
                out['targets'][label] = {'ok': False, 'reason': why, 'depth': depth}
                link.close()
                continue
            links[label] = link
            out['targets'][label] = {'ok': True, 'runs': [], 'depth': depth}
        main = {k: v for k, v in links.items() if not k.endswith('_deep')}
        if main and 'rates' in parts:
            log(f'node benchmark: paired latency ({sizes.node_ping} commands each)')
            for label, res in driver.ping_pong(list(main.values()), sizes.node_ping).items():
                out['targets'][label]['latency'] = res
        for rate in sorted(set(sizes.node_rates) | set(sizes.node_deep_rates)):
            if 'rates' not in parts:
                break
            for label, link in links.items():  # targets alternate: same conditions
                if rate in (sizes.node_deep_rates if label.endswith('_deep') else sizes.node_rates):
                    log(f'node benchmark: {label} at {rate:g} Hz')
                    out['targets'][label]['runs'].append(
                        driver.rate_run(
                            link, rate, sizes.node_seconds, target_pid=procs[label].proc.pid
                        )
                    )
        for label in links:
            out['targets'][label]['sustained_rate'] = sustained_rate(out['targets'][label]['runs'])
        if 'node' in links and 'floods' in parts:  # commands beside floods on the same node
            out['targets']['node']['floods'] = _floods(
                driver,
                links['node'],
                specs_ns['node'],
                sizes.node_seconds,
                env,
                work,
                procs['node'].proc.pid,
            )
        if include_node and sizes.node_all_rate and 'all_outputs' in parts:
            # the processes measured so far stop first: they would share the CPU and
            # /diagnostics with the every-output case
            for link in links.values():
                link.close()
            links.clear()
            for p in procs.values():
                p.stop()
            procs.clear()

            out['all_outputs_rate'] = sizes.node_all_rate
            out['all_outputs'] = bench_all_outputs(
                driver,
                env,
                work,
                tag,
                sizes.node_all_rate,
                sizes.node_seconds,
                sizes.node_warmup,
                sizes.node_all_scenes,
            )
    finally:
        for link in links.values():
            link.close()
        driver.close()
        for p in procs.values():
            p.stop()
    return out


def _floods(
    driver: Driver, link: Link, ns: str, seconds: float, env: dict, work: Path, pid: int
) -> list[dict]:
    """Commands at FLOOD_COMMAND_HZ alone (kind 'none': the reference), then beside each of
    FLOODS, one after another on the same node; each flood from a process of its own
    (flood.py), started and matched before the commands start and running past their end."""
    log(f'node benchmark: node at {FLOOD_COMMAND_HZ:g} Hz, no flood (the reference)')
    run = driver.rate_run(link, FLOOD_COMMAND_HZ, seconds, target_pid=pid)
    run.update(flood_rate=0.0, flood_sent=0, flood_kind=FloodKind.NONE)
    runs = [run]
    for kind, topic, rate in FLOODS:
        sent_file = work / f'flood_{kind}.json'
        proc = Proc(
            [sys.executable, '-m', 'linkage_ros.bench.flood']
            + ['--topic', f'{ns}/linkage_node/{topic}', '--kind', kind, '--rate', f'{rate:g}']
            + ['--seconds', f'{seconds + 0.5:g}', '--out', str(sent_file)],
            env,
            work,
            f'flood_{kind}',
        )
        try:
            why = _await_ready(driver, proc)
            if why is not None:
                runs.append({'flood_kind': kind, 'ok': False, 'reason': why})
                continue
            log(
                f'node benchmark: node at {FLOOD_COMMAND_HZ:g} Hz beside a {rate:g} Hz '
                f'~/{topic} flood ({kind})'
            )
            run = driver.rate_run(link, FLOOD_COMMAND_HZ, seconds, target_pid=pid)
            proc.proc.wait(timeout=60)
            try:
                sent = json.loads(sent_file.read_text())['sent']
            except (OSError, ValueError, KeyError):
                sent = None
            run.update(flood_rate=rate, flood_sent=sent, flood_kind=kind, flood_topic=topic)
            runs.append(run)
        finally:
            proc.stop()
        driver.spin_for(2.0 if kind is not FloodKind.TRAJECTORY else 8.0)  # the node catches up
    return runs


def _await_ready(driver: Driver, proc: Proc, timeout: float = 30.0) -> str | None:
    """Wait for a flood process's 'ready' (its publisher matched the node)."""
    t_end = time.monotonic() + timeout
    while 'ready' not in Path(proc.out.name).read_text(errors='replace'):
        if not proc.alive() or time.monotonic() > t_end:
            return f'the flood did not start: {proc.tail()}'
        driver.spin_for(0.05)
    return None
