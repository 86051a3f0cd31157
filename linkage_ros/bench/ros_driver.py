"""The ROS machinery the node benchmarks share: the bare rclpy relay, node processes, and the
driver that publishes commands and times the answers (floods: flood.py, a process of its
own)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np


def relay_script() -> Path | None:
    p = Path(__file__).resolve().parents[2] / 'bench' / 'relay_node.py'
    return p if p.is_file() else None


class Proc:
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


def ros_env(domain: int) -> dict:
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


class Link:
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

    def link(self, label, cmd_topic, out_topic, **kw) -> Link:
        return Link(self, label, cmd_topic, out_topic, **kw)

    def spin_for(self, seconds: float):
        t_end = time.monotonic() + seconds
        while time.monotonic() < t_end:
            self.exec.spin_once(timeout_sec=0.005)

    def connect(self, link: Link, warmup: int, timeout: float = 20.0) -> str | None:
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
        self, links: Sequence[Link], n: int, period: float = 0.005, timeout: float = 0.5
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
        link: Link,
        rate: float,
        seconds: float,
        drain_timeout: float = 2.0,
        target_pid: int | None = None,
    ) -> dict:
        """Commands at ``rate`` Hz for ``seconds`` (absolute schedule, spinning in between);
        then drain until every answer is in or none arrived for ``drain_timeout`` s. With
        ``target_pid``, the CPU time and run-queue wait of the target's main thread and the
        driver's during the run are recorded too (sched_during), and the CPU time of the whole
        target process (every thread) from the first command to the last answer, per answer
        (target_cpu_per_answer_us)."""
        link.recv.clear()
        pids = {'driver': os.getpid(), **({'target': target_pid} if target_pid else {})}
        sched = {label: main_thread_sched(pid) for label, pid in pids.items()}
        cpu_start = process_cpu_s(target_pid) if target_pid else None
        cpu_last: list[float | None] = [cpu_start]
        kids_start = children_cpu_s(target_pid) if target_pid else None
        kids_last: list[float | None] = [kids_start]
        n = max(1, int(round(rate * seconds)))
        period = 1.0 / rate
        stamps = []
        t0 = time.perf_counter()
        i = 0
        while i < n:
            now = time.perf_counter()
            due = t0 + i * period
            if now >= due:
                stamps.append(link.send())
                i += 1
                self.exec.spin_once(timeout_sec=0)
            else:
                self.exec.spin_once(timeout_sec=min(due - now, 0.002))
        send_seconds = time.perf_counter() - t0
        sched_run = sched_during(sched, pids)
        if target_pid:  # the target's CPU up to its last answer (not the drain's idle wait)

            def on_progress() -> None:
                cpu_last[0] = process_cpu_s(target_pid)
                kids_last[0] = children_cpu_s(target_pid)

            self._drain(link.recv, stamps, drain_timeout, on_progress)
        else:
            self._drain(link.recv, stamps, drain_timeout)
        got = [link.recv[s] - s for s in stamps if s in link.recv]
        got_at = [link.recv[s] for s in stamps if s in link.recv]
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
        cpu_run = (
            cpu_last[0] - cpu_start if cpu_start is not None and cpu_last[0] is not None else None
        )
        kids_run = (
            kids_last[0] - kids_start
            if kids_start is not None and kids_last[0] is not None
            else None
        )
        return {
            **answer_gaps(stamps, got_at),
            **sched_run,
            'target_process_cpu_ms': None if cpu_run is None else cpu_run * 1e3,
            'target_children_cpu_ms': None if kids_run is None else kids_run * 1e3,
            'target_cpu_per_answer_us': None
            if cpu_run is None or not got
            else cpu_run * 1e6 / len(got),
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

    def _drain(self, recv, stamps, timeout, on_progress: Callable[[], None] | None = None):
        """Spin until every answer to ``stamps`` is in or none arrived for ``timeout`` s;
        ``on_progress`` is called whenever more have arrived (and at the end, all in)."""
        want = set(stamps)
        last_count, last_change = -1, time.monotonic()
        while True:
            have = len(want & recv.keys())
            if have != last_count and on_progress is not None:
                on_progress()
            if have == len(want):
                return
            if have != last_count:
                last_count, last_change = have, time.monotonic()
            elif time.monotonic() - last_change > timeout:
                return
            self.exec.spin_once(timeout_sec=0.01)


def main_thread_sched(pid: int) -> tuple[int, int] | None:
    """(ns on a CPU, ns runnable but waiting for one) of process ``pid``'s main thread so far
    (/proc/<pid>/task/<pid>/schedstat), or None where the kernel does not say."""
    try:
        with open(f'/proc/{pid}/task/{pid}/schedstat') as fh:
            on_cpu, waiting, _ = fh.read().split()
        return int(on_cpu), int(waiting)
    except (OSError, ValueError):
        return None


def process_cpu_s(pid: int) -> float | None:
    """CPU seconds (user + system) process ``pid`` has used so far, every thread (also those
    that ended) counted (/proc/<pid>/stat; clock ticks, 10 ms on Linux), or None where the
    kernel does not say."""
    try:
        with open(f'/proc/{pid}/stat') as fh:
            text = fh.read()
        fields = text[text.rindex(')') + 2 :].split()  # the name may hold spaces
        return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')
    except (OSError, ValueError, IndexError):
        return None


def children_cpu_s(pid: int) -> float | None:
    """CPU seconds the child processes of ``pid`` running now have used so far (the node's
    plan worker; /proc/<pid>/task/*/children), or None where the kernel does not say."""
    try:
        kids = [
            int(k)
            for task in os.listdir(f'/proc/{pid}/task')
            for k in Path(f'/proc/{pid}/task/{task}/children').read_text().split()
        ]
    except (OSError, ValueError):
        return None
    return sum(process_cpu_s(k) or 0.0 for k in kids)


def sched_during(before: dict[str, tuple[int, int] | None], pids: dict[str, int]) -> dict:
    """CPU time and run-queue wait (ms) of each main thread since ``before``: a thread that is
    runnable but waits for a CPU (other processes on the machine) answers nothing meanwhile."""
    out: dict[str, Any] = {}
    for label, pid in pids.items():
        now, then = main_thread_sched(pid), before.get(label)
        if now is None or then is None:
            continue
        out[f'{label}_cpu_ms'] = (now[0] - then[0]) / 1e6
        out[f'{label}_runqueue_ms'] = (now[1] - then[1]) / 1e6
    return out


def answer_gaps(sent_ns: Sequence[int], answered_ns: Sequence[int]) -> dict[str, Any]:
    """The largest gap between consecutive answers of a run (ms), when it began (s after the
    first command) and the largest gap between consecutive sends around it: a stall of the
    target shows as an answer gap while the sends go on; one of the driver as both."""
    if len(answered_ns) < 2:
        return {'max_gap_ms': None, 'max_gap_at_s': None, 'send_gap_ms': None}
    arrivals = np.sort(np.asarray(answered_ns, np.int64))
    gaps = np.diff(arrivals)
    k = int(np.argmax(gaps))
    start, end = int(arrivals[k]), int(arrivals[k + 1])
    sent = np.asarray(sent_ns, np.int64)
    window = sent[(sent >= start - 50_000_000) & (sent <= end)]
    send_gap = float(np.max(np.diff(window))) / 1e6 if len(window) >= 2 else None
    return {
        'max_gap_ms': float(gaps[k]) / 1e6,
        'max_gap_at_s': (start - int(sent[0])) / 1e9 if len(sent) else None,
        'send_gap_ms': send_gap,
    }
