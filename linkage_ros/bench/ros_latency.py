"""The node's command -> joint_states latency and loss-free rate against a bare rclpy relay."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .settings import DEFAULT_DEPTH, Sizes, _log

# =============================================================================================
# (c) node latency and loss-free rate vs a bare rclpy relay
# =============================================================================================


#: the flood measurement: commands at this rate beside hostile ~/target requests at that one
FLOOD_COMMAND_HZ = 500.0
FLOOD_RATE_HZ = 100.0


def relay_script() -> Path | None:
    p = Path(__file__).resolve().parents[2] / 'bench' / 'relay_node.py'
    return p if p.is_file() else None


class _Proc:
    """A ROS process started (and stopped) by the benchmark; output goes to files."""

    def __init__(self, argv: list[str], env: dict, workdir: Path, label: str):
        self.label = label
        self.out = open(workdir / f'{label}.out', 'wb')  # noqa: SIM115 (lives with the process)
        self.err_path = workdir / f'{label}.err'
        self.err = open(self.err_path, 'wb')  # noqa: SIM115 (lives with the process)
        self.proc = subprocess.Popen(
            argv,
            env=env,
            stdout=self.out,
            stderr=self.err,
            stdin=subprocess.DEVNULL,
            start_new_session=True,
        )

    def tail(self, n: int = 600) -> str:
        try:
            txt = self.err_path.read_text(errors='replace') + Path(self.out.name).read_text(
                errors='replace'
            )
        except OSError:
            return ''
        return txt.strip()[-n:]

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 5.0):
        if self.proc.poll() is None:
            try:
                self.proc.send_signal(signal.SIGINT)
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.terminate()
                try:
                    self.proc.wait(timeout=3)
                except subprocess.TimeoutExpired:
                    self.proc.kill()
                    self.proc.wait()
        self.out.close()
        self.err.close()


def _ros_env(domain: int) -> dict:
    env = dict(os.environ)
    for k in ('ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS'):
        env.pop(k, None)
    env.update(
        {
            'ROS_DOMAIN_ID': str(domain),
            'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
            'AMENT_PREFIX_PATH': os.environ.get('AMENT_PREFIX_PATH', sys.prefix),
            'PYTHONUNBUFFERED': '1',
            'RCUTILS_COLORIZED_OUTPUT': '0',
        }
    )
    return env


class _Link:
    """One target under test as the driver sees it: a command publisher, an answer subscription
    and the arrival time of every answer, keyed by the command stamp (ns)."""

    def __init__(
        self,
        driver: Driver,
        label: str,
        cmd_topic: str,
        out_topic: str,
        names: list[str] | None = None,
        value: Callable[[int], list] | None = None,
    ):
        """``names`` / ``value``: this target's command (default: the driver's)."""
        from sensor_msgs.msg import JointState

        self.label = label
        self.driver = driver
        self.names = names if names is not None else driver.names
        self.value = value if value is not None else driver.value
        self.recv: dict[int, int] = {}
        self.pub = driver.node.create_publisher(JointState, cmd_topic, driver.qos)
        self.sub = driver.node.create_subscription(JointState, out_topic, self._on_msg, driver.qos)
        self.k = 0

    def _on_msg(self, msg):
        t = time.time_ns()
        self.recv.setdefault(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, t)

    def matched(self) -> bool:
        return self.pub.get_subscription_count() >= 1 and self.sub.get_publisher_count() >= 1

    def send(self) -> int:
        """Publish the next command; returns its stamp (ns, unique and increasing)."""
        msg = self.driver.msg_type()
        t = max(time.time_ns(), self.driver.last_stamp + 1)
        self.driver.last_stamp = t
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t, 1_000_000_000)
        msg.name = self.names
        msg.position = self.value(self.k)
        self.k += 1
        self.pub.publish(msg)
        return t

    def close(self):
        self.driver.node.destroy_subscription(self.sub)
        self.driver.node.destroy_publisher(self.pub)


class Driver:
    """Publishes JointState commands and collects the answers, in its own rclpy context in this
    process (single-threaded executor: publish when due, otherwise spin). The same driver runs
    every target, so their numbers compare."""

    def __init__(self, domain: int, names: list[str], value: Callable[[int], list]):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState

        self.rclpy = rclpy
        self.msg_type = JointState
        self.names, self.value = names, value
        self.last_stamp = 0
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node(f'linkage_bench_driver_{os.getpid()}', context=self.ctx)
        self.exec = SingleThreadedExecutor(context=self.ctx)
        self.exec.add_node(self.node)
        # deep queues on the driver's side so the driver is never the one that drops
        self.qos = QoSProfile(
            reliability=ReliabilityPolicy.RELIABLE,
            history=HistoryPolicy.KEEP_LAST,
            depth=1000,
            durability=DurabilityPolicy.VOLATILE,
        )

    def close(self):
        try:
            self.exec.shutdown()
            self.node.destroy_node()
        finally:
            self.rclpy.try_shutdown(context=self.ctx)

    def link(self, label, cmd_topic, out_topic, **kw) -> _Link:
        return _Link(self, label, cmd_topic, out_topic, **kw)

    def spin_for(self, seconds: float):
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            self.exec.spin_once(timeout_sec=0.005)

    def connect(self, link: _Link, warmup: int, timeout: float = 20.0) -> str | None:
        """Wait for discovery both ways, then until ``warmup`` commands have been answered (the
        first ones pay for lazy set-up). Returns None, or why the target is not usable."""
        t_end = time.monotonic() + timeout
        while not link.matched():
            if time.monotonic() > t_end:
                return (
                    f'no discovery within {timeout:g} s (command subscribers '
                    f'{link.pub.get_subscription_count()}, answer publishers '
                    f'{link.sub.get_publisher_count()})'
                )
            self.exec.spin_once(timeout_sec=0.05)
        t_end = time.monotonic() + timeout
        sent = 0
        while len(link.recv) < warmup:
            if time.monotonic() > t_end:
                return f'{len(link.recv)} of {sent} warm-up commands answered within {timeout:g} s'
            link.send()
            sent += 1
            self.spin_for(0.01)
        self.spin_for(0.2)
        link.recv.clear()
        return None

    def ping_pong(
        self, links: Sequence[_Link], n: int, period: float = 0.005, timeout: float = 0.5
    ) -> dict[str, dict]:
        """Latency without queueing: one command outstanding at a time, the targets taking turns
        (paired samples under the same conditions), a new command every ``period`` s."""
        lat: dict[str, list[float]] = {l.label: [] for l in links}
        lost = {l.label: 0 for l in links}
        t_next = time.perf_counter()
        for _ in range(n):
            for l in links:
                while time.perf_counter() < t_next:
                    self.exec.spin_once(
                        timeout_sec=max(0.0, min(t_next - time.perf_counter(), 0.002))
                    )
                t_next += period
                s = l.send()
                t_end = time.monotonic() + timeout
                while s not in l.recv and time.monotonic() < t_end:
                    self.exec.spin_once(timeout_sec=0.002)
                if s in l.recv:
                    lat[l.label].append((l.recv[s] - s) / 1e6)
                else:
                    lost[l.label] += 1
        out = {}
        for l in links:
            a = np.asarray(lat[l.label])
            out[l.label] = {
                'n': int(a.size),
                'timeouts': lost[l.label],
                'p50_ms': float(np.percentile(a, 50)) if a.size else None,
                'p99_ms': float(np.percentile(a, 99)) if a.size else None,
                'max_ms': float(a.max()) if a.size else None,
            }
            l.recv.clear()
        return out

    def rate_run(
        self,
        link: _Link,
        rate: float,
        seconds: float,
        drain_timeout: float = 2.0,
        flood: Flood | None = None,
    ) -> dict:
        """Commands at ``rate`` Hz for ``seconds`` (absolute schedule, spinning in between);
        then drain until every answer is in or none arrived for ``drain_timeout`` s. With
        ``flood``, its hostile requests go out at their own rate meanwhile."""
        link.recv.clear()
        n = max(1, int(round(rate * seconds)))
        period = 1.0 / rate
        stamps = []
        t0 = time.perf_counter()
        i = j = 0
        while i < n:
            now = time.perf_counter()
            due = t0 + i * period
            if flood is not None and now >= t0 + j / flood.rate:
                flood.send(j)
                j += 1
            if now >= due:
                stamps.append(link.send())
                i += 1
                self.exec.spin_once(timeout_sec=0)
            else:
                self.exec.spin_once(timeout_sec=min(due - now, 0.002))
        send_seconds = time.perf_counter() - t0
        self._drain(link.recv, stamps, drain_timeout)
        got = [link.recv[s] - s for s in stamps if s in link.recv]
        lat = np.asarray(got, float) / 1e6  # ms
        # the most commands sent in any 10 ms (10 at an even 1 kHz): after a stall of the
        # driver itself the absolute schedule sends what is overdue back to back, a burst a
        # target's queue must hold
        sent_ns = np.asarray(stamps, np.int64)
        burst = (
            int(np.max(np.searchsorted(sent_ns, sent_ns + 10_000_000) - np.arange(len(sent_ns))))
            if len(sent_ns)
            else 0
        )
        self.spin_for(0.3)
        link.recv.clear()
        return {
            'rate': rate,
            'sent': len(stamps),
            'received': len(got),
            'lost': len(stamps) - len(got),
            'achieved_rate': len(stamps) / send_seconds if send_seconds > 0 else None,
            'p50_ms': float(np.percentile(lat, 50)) if lat.size else None,
            'p99_ms': float(np.percentile(lat, 99)) if lat.size else None,
            'max_ms': float(lat.max()) if lat.size else None,
            'burst_10ms': burst,
        }

    def _drain(self, recv, stamps, timeout):
        want = set(stamps)
        last_count, last_change = -1, time.monotonic()
        while True:
            have = len(want & recv.keys())
            if have == len(want):
                return
            if have != last_count:
                last_count, last_change = have, time.monotonic()
            elif time.monotonic() - last_change > timeout:
                return
            self.exec.spin_once(timeout_sec=0.01)


class Flood:
    """Hostile ~/target requests at ``rate`` Hz from the driver, of one ``kind``: 'new_sets'
    names a new, unknown set of names every time (each used to compile a solver and push a
    cached one out), 'huge' is a message with 10^5 names (2 MB serialised)."""

    KINDS = ('new_sets', 'huge')

    def __init__(self, driver: Driver, topic: str, rate: float, kind: str):
        self.rate, self.kind = rate, kind
        self.pub = driver.node.create_publisher(driver.msg_type, topic, driver.qos)
        from rclpy.serialization import serialize_message

        big = driver.msg_type()
        big.name = [f'n{k}' for k in range(10**5)]
        big.position = [0.5] * len(big.name)
        self.big = serialize_message(big)  # published as bytes: the driver pays for it once
        self.msg_type = driver.msg_type
        self.sent = 0

    def send(self, j: int) -> None:
        msg: Any
        if self.kind == 'huge':
            msg = self.big
        else:
            msg = self.msg_type()
            msg.name = [f'flood_{j}_a', f'flood_{j}_b']
            msg.position = [0.1, 0.2]
        self.pub.publish(msg)
        self.sent += 1


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
) -> dict:
    """The relay and the node run as separate processes under one driver: first a paired
    latency phase (ping-pong, targets taking turns), then each target alone at every rate.
    ``node_argv`` replaces the node's command line (e.g. to measure a patched node)."""
    try:
        import rclpy  # noqa: F401
        from sensor_msgs.msg import JointState  # noqa: F401
    except Exception as exc:  # noqa: BLE001
        return {'skipped': f'rclpy / sensor_msgs unavailable: {exc}'}
    domain = random.Random(os.getpid() ^ time.time_ns()).randint(1, 200)
    env = _ros_env(domain)
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
    procs: dict[str, _Proc] = {}
    links: dict[str, _Link] = {}
    try:
        for label, argv, _cmd_topic, _out_topic, depth in specs:
            _log(
                f'node benchmark: starting {label} ({" ".join(Path(a).name for a in argv[:3])}, '
                f'queue depth {depth}) on ROS domain {domain}'
            )
            procs[label] = _Proc(argv, env, work, label)
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
        if main:
            _log(f'node benchmark: paired latency ({sizes.node_ping} commands each)')
            for label, res in driver.ping_pong(list(main.values()), sizes.node_ping).items():
                out['targets'][label]['latency'] = res
        for rate in sorted(set(sizes.node_rates) | set(sizes.node_deep_rates)):
            for label, link in links.items():  # targets alternate: same conditions
                if rate in (sizes.node_deep_rates if label.endswith('_deep') else sizes.node_rates):
                    _log(f'node benchmark: {label} at {rate:g} Hz')
                    out['targets'][label]['runs'].append(
                        driver.rate_run(link, rate, sizes.node_seconds)
                    )
        for label in links:
            out['targets'][label]['sustained_rate'] = sustained_rate(out['targets'][label]['runs'])
        if 'node' in links:  # commands beside a flood of hostile targets on the same node
            out['targets']['node']['floods'] = []
            for kind in Flood.KINDS:
                flood = Flood(
                    driver, f'{specs_ns["node"]}/linkage_node/target', FLOOD_RATE_HZ, kind
                )
                _log(
                    f'node benchmark: node at {FLOOD_COMMAND_HZ:g} Hz beside a '
                    f'{FLOOD_RATE_HZ:g} Hz ~/target flood ({kind})'
                )
                driver.spin_for(1.0)  # the flood's publisher matched
                run = driver.rate_run(
                    links['node'], FLOOD_COMMAND_HZ, sizes.node_seconds, flood=flood
                )
                run.update(flood_rate=FLOOD_RATE_HZ, flood_sent=flood.sent, flood_kind=kind)
                out['targets']['node']['floods'].append(run)
                driver.spin_for(2.0)  # the node catches up before the next
        if include_node and sizes.node_all_rate:
            from .all_outputs import bench_all_outputs

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
