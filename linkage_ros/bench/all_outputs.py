"""The node with every output subscribed (joint_states, every ~/points/<p>, ~/markers, ~/status
and /diagnostics) answering a command stream, beside a bare rclpy relay at the same rate in the
same run (they take turns, one scene after another).

The driver measures joint_states as for every other target; the other outputs are subscribed by
a listener in its own process (as RViz or a diagnostic aggregator would be), which counts what
it receives: ``python -m linkage_ros.bench.all_outputs --scene S --ns NS --out FILE`` (SIGINT:
drain, write ``{topic: messages}`` as JSON to FILE, exit). A listener in the driver's process
would make the driver the bottleneck (at 1 kHz the excavator's outputs are ~5000 messages/s) and
the node's latency would include the driver's work.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import os
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .ros_driver import Driver, Link, Proc, relay_script
from .settings import DEFAULT_DEPTH, ListenerExecutor, log


def all_output_scenes(chosen: tuple[str, ...] = ()) -> tuple[str, ...]:
    """The scenes measured: ``chosen``, or every packaged scene."""
    if chosen:
        return chosen
    from ..resources import config_dir

    return tuple(sorted(p.stem for p in config_dir().glob('*.yaml')))


def command_values(scene: str) -> tuple[list[str], Callable[[int], list[float]]]:
    """The scene's actuators and a command stream through their ranges: a limited actuator
    oscillates inside its limits, an unlimited angle steps through full turns."""
    from ..core.model import Scene
    from ..core.motion import input_ranges
    from ..resources import scene_path

    mech = Scene.from_yaml(scene_path(scene)).mechanism
    ranges = input_ranges(mech)
    names = list(mech.actuators)
    plans: list[tuple[float | None, float | None, int]] = []
    for k, a in enumerate(names):
        lo, hi = ranges[a]
        if lo is None or hi is None:
            plans.append((None, None, k))
        else:
            plans.append((lo, hi, k))

    def value(i: int) -> list[float]:
        out = []
        for lo, hi, k in plans:
            if lo is None or hi is None:
                out.append(1.0 + 0.0105 * (i % 600))
            else:
                out.append(lo + (hi - lo) * (0.5 + 0.45 * math.sin(0.01 * (k + 1) * i)))
        return out

    return names, value


def outputs_of(scene: str, ns: str) -> list[tuple[Any, str, Any]]:
    """(type, topic, QoS) of every output of a node in ``ns`` other than joint_states."""
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from geometry_msgs.msg import PointStamped
    from visualization_msgs.msg import MarkerArray

    from ..core.model import Scene
    from ..publishing import latched_qos
    from ..resources import scene_path

    mech = Scene.from_yaml(scene_path(scene)).mechanism
    base = f'{ns}/linkage_node'
    return [
        *[(PointStamped, f'{base}/points/{p}', None) for p in mech.outputs],
        (MarkerArray, f'{base}/markers', latched_qos()),
        (DiagnosticStatus, f'{base}/status', None),
        (DiagnosticArray, '/diagnostics', None),
    ]


#: the listener's reader depth: it never drops while it catches up after the stream
LISTENER_DEPTH = 100_000


def _count_one(count: Callable[[str], None], topic: str, _msg: bytes) -> None:
    count(topic)


#: the every-output node run whose listener is a plain rclpy one (SingleThreadedExecutor)
PLAIN_LISTENER_LABEL = 'node_plain_listener'


def ready_file(out: Path) -> Path:
    """The file the listener writing its counts to ``out`` creates when it is ready."""
    return out.with_suffix('.ready')


def listen(
    scene: str,
    ns: str,
    out: Path,
    quiet_s: float = 0.5,
    executor_kind: ListenerExecutor = ListenerExecutor.EVENTS,
) -> int:
    """The listener process: count every message of ``outputs_of(scene, ns)`` until SIGINT or
    SIGTERM, then take what is still queued (until none arrived for ``quiet_s``) and write the
    counts to ``out``. ``executor_kind``: which rclpy executor it spins."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions

    deep = QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        history=HistoryPolicy.KEEP_LAST,
        depth=LISTENER_DEPTH,
        durability=DurabilityPolicy.VOLATILE,
    )
    stop: list[int] = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.append(1))
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(f'linkage_bench_listener_{os.getpid()}')
    counts: dict[str, int] = {}
    last = [time.monotonic()]

    def count(topic: str) -> None:
        counts[topic] = counts.get(topic, 0) + 1
        last[0] = time.monotonic()

    # raw: counting needs no deserialisation (the cheapest reader rclpy has)
    subs = [
        node.create_subscription(
            kind, topic, functools.partial(_count_one, count, topic), qos or deep, raw=True
        )
        for kind, topic, qos in outputs_of(scene, ns)
    ]
    executor: Any = None
    if (
        executor_kind is ListenerExecutor.EVENTS
    ):  # the cheapest executor rclpy has: a C++ display's stand-in
        try:
            from rclpy.experimental import EventsExecutor

            executor = EventsExecutor()
        except ImportError:
            pass
    if executor is None:
        executor = SingleThreadedExecutor()
    executor.add_node(node)
    try:
        # ready (a file beside ``out``) once every reader has matched the node's writer: the
        # graph seen from the driver says only that the readers exist
        while not stop and not all(sub.get_publisher_count() >= 1 for sub in subs):
            executor.spin_once(timeout_sec=0.05)
        ready_file(out).touch()
        while not stop or time.monotonic() - last[0] < quiet_s:
            executor.spin_once(timeout_sec=0.05)
        tmp = out.with_suffix('.tmp')
        tmp.write_text(json.dumps(counts))
        os.replace(tmp, out)
    finally:
        executor.shutdown()
        for sub in subs:
            node.destroy_subscription(sub)
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def bench_all_outputs(
    driver: Driver,
    env: dict,
    work: Path,
    tag: str,
    rate: float,
    seconds: float,
    warmup: int,
    scenes: tuple[str, ...] = (),
) -> dict:
    """{scene: {'relay': run, 'node': run, PLAIN_LISTENER_LABEL: run}} at ``rate`` Hz, each
    node run with 'outputs' ({topic: messages} its listener counted): the node's runs differ
    only in the listener's executor."""

    out: dict[str, Any] = {}
    script = relay_script()
    for scene in all_output_scenes(scenes):
        names, value = command_values(scene)
        ns_node, ns_relay = f'/{tag}_all_{scene}', f'/{tag}_allrelay_{scene}'
        procs = {
            'node': Proc(
                [sys.executable, '-m', 'linkage_ros.node']
                + ['--ros-args', '-r', f'__ns:={ns_node}', '-p', f'scene:={scene}'],
                env,
                work,
                f'all_{scene}',
            )
        }
        if script is not None:
            procs['relay'] = Proc(
                [sys.executable, str(script), '--depth', str(DEFAULT_DEPTH)]
                + ['--ros-args', '-r', f'__ns:={ns_relay}'],
                env,
                work,
                f'allrelay_{scene}',
            )
        links: dict[str, Link] = {}
        res: dict[str, Any] = {'actuators': names}
        try:
            if 'relay' in procs:
                links['relay'] = driver.link(
                    f'allrelay_{scene}',
                    f'{ns_relay}/relay_node/command',
                    f'{ns_relay}/joint_states',
                    names=names,
                    value=value,
                )
            links['node'] = driver.link(
                f'all_{scene}',
                f'{ns_node}/linkage_node/command',
                f'{ns_node}/joint_states',
                names=names,
                value=value,
            )
            unusable: dict[str, str] = {}
            for label, link in links.items():
                why = driver.connect(link, warmup)
                if why is not None:
                    unusable[label] = f'{why}; {procs[label].tail()}'
                    res[label] = {'ok': False, 'reason': unusable[label]}
            # the relay, then the node with each listener: the same conditions
            runs: list[tuple[str, str, ListenerExecutor | None]] = [
                ('relay', 'relay', None),
                ('node', 'node', ListenerExecutor.EVENTS),
                (PLAIN_LISTENER_LABEL, 'node', ListenerExecutor.SINGLE),
            ]
            for label, target, executor in runs:
                if target not in links:
                    continue
                if target in unusable:
                    res[label] = {'ok': False, 'reason': unusable[target]}
                    continue
                listener = None
                if executor is not None:  # every other output subscribed, by another process
                    counts_file = work / f'all_{scene}_{executor}_counts.json'
                    listener = procs[f'listener_{executor}'] = Proc(
                        [sys.executable, '-m', 'linkage_ros.bench.all_outputs']
                        + ['--scene', scene, '--ns', ns_node, '--out', str(counts_file)]
                        + ['--executor', executor],
                        env,
                        work,
                        f'all_{scene}_listener_{executor}',
                    )
                    ready_file(counts_file).unlink(missing_ok=True)
                    why = _await_listener(driver, scene, ns_node, ready=ready_file(counts_file))
                    if why is not None:
                        res[label] = {'ok': False, 'reason': f'{why}; {listener.tail()}'}
                        continue
                log(f'node benchmark: every output on, {scene}, {label} at {rate:g} Hz')
                pid = procs[target].proc.pid
                run = driver.rate_run(links[target], rate, seconds, target_pid=pid)
                if listener is not None:
                    listener.stop(timeout=30.0)
                    try:
                        run['outputs'] = json.loads(counts_file.read_text())
                    except (OSError, ValueError) as exc:
                        res[label] = {'ok': False, 'reason': f'listener: {exc}; {listener.tail()}'}
                        continue
                    run['listener'] = executor
                    why = _await_listener(driver, scene, ns_node, gone=True)
                    if why is not None:
                        res[label] = {'ok': False, 'reason': why}
                        continue
                res[label] = {'ok': True, **run}
        finally:
            for link in links.values():
                link.close()
            for p in procs.values():
                p.stop()
        out[scene] = res
    return out


def _await_listener(
    driver: Driver,
    scene: str,
    ns: str,
    timeout: float = 20.0,
    gone: bool = False,
    ready: Path | None = None,
) -> str | None:
    """Wait until every output topic has a subscriber (the listener; the driver has none) and
    the listener says its readers have matched the node's writers (``ready``, a file it
    creates), or with ``gone`` until no topic has one (the listener stopped: the next one
    starts alone)."""
    topics = [topic for _, topic, _ in outputs_of(scene, ns)]
    t_end = time.monotonic() + timeout
    while True:
        if gone:
            missing = [t for t in topics if driver.node.count_subscribers(t) > 0]
            if not missing:
                return None
            if time.monotonic() > t_end:
                return f'the output listener still subscribes {missing} after {timeout:g} s'
            driver.spin_for(0.05)
            continue
        missing = [t for t in topics if driver.node.count_subscribers(t) < 1]
        if ready is not None and not ready.exists():
            missing.append(f'(the listener has not matched every writer: {ready.name})')
        if not missing:
            driver.spin_for(
                2.0
            )  # the node's writers match the listener's readers; discovery settles
            return None
        if time.monotonic() > t_end:
            return f'the output listener did not subscribe {missing} within {timeout:g} s'
        driver.spin_for(0.05)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description='count the outputs of a linkage_node (bench helper; SIGINT writes the counts)'
    )
    parser.add_argument('--scene', required=True)
    parser.add_argument('--ns', required=True, help="the node's namespace, e.g. /bench_all")
    parser.add_argument('--out', required=True, type=Path, help='JSON file for the counts')
    parser.add_argument(
        '--executor',
        choices=[e.value for e in ListenerExecutor],
        default=ListenerExecutor.EVENTS.value,
        help="rclpy's EventsExecutor (default) or a plain SingleThreadedExecutor",
    )
    opts = parser.parse_args(argv)
    return listen(opts.scene, opts.ns, opts.out, executor_kind=ListenerExecutor(opts.executor))


if __name__ == '__main__':
    sys.exit(main())
