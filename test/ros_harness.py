"""Launch-free helpers for node tests over real DDS.

* :class:`NodeProcess` runs ``linkage_node`` as a subprocess (``python -m linkage_ros.node``) in
  its own namespace, on a given ROS domain, discovery limited to this host, with a parameter
  file written for it; stdout / stderr go to files (no pipe can fill up and block the node).
* :class:`RosHarness` is the test side: its own rclpy Context on the same domain, one node, a
  single-threaded executor, reliable publishers and collecting subscriptions, and waits that
  poll the graph (matched publisher / subscription counts), never fixed sleeps.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import rclpy
import yaml
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from scenes import REPO

QOS = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    durability=DurabilityPolicy.VOLATILE,
)

NODE_NAME = 'linkage_node'


def random_domain_id() -> int:
    """A ROS domain in [1, 200], different per test run (pid and clock seeded)."""
    return random.Random(os.getpid() ^ time.time_ns()).randint(1, 200)


def ros_env(domain_id: int) -> dict[str, str]:
    """The environment for a node process: our domain, localhost discovery, the venv prefix."""
    env = dict(os.environ)
    for k in (
        'ROS_LOCALHOST_ONLY',
        'ROS_STATIC_PEERS',
        'FASTRTPS_DEFAULT_PROFILES_FILE',
        'FASTDDS_DEFAULT_PROFILES_FILE',
    ):
        env.pop(k, None)
    env.update(
        {
            'ROS_DOMAIN_ID': str(domain_id),
            'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
            'AMENT_PREFIX_PATH': os.environ.get('AMENT_PREFIX_PATH', sys.prefix),
            'PYTHONUNBUFFERED': '1',
            'RCUTILS_COLORIZED_OUTPUT': '0',
        }
    )
    return env


class NodeProcess:
    """One ``linkage_node`` subprocess.

    ``params`` are written to a parameter file keyed by the node's fully qualified name
    (``/<namespace>/linkage_node``); ``namespace`` keeps parallel test runs apart even on one
    domain. ``args`` are extra ``--ros-args`` arguments. ``publish_rate`` is 0 (answers only)
    unless ``params`` gives it: most tests count the messages each request causes.
    """

    def __init__(
        self,
        workdir: Path,
        domain_id: int,
        params: dict[str, Any] | None = None,
        namespace: str | None = None,
        args: Iterable[str] = (),
    ):
        self.workdir = Path(workdir)
        self.workdir.mkdir(parents=True, exist_ok=True)
        self.domain_id = domain_id
        self.namespace = namespace or f'/lk{os.getpid()}_{random.randrange(1 << 30)}'
        self.params = {'publish_rate': 0.0, **(params or {})}
        self.args = list(args)
        self.proc: subprocess.Popen | None = None
        self.stdout_path = self.workdir / 'stdout.txt'
        self.stderr_path = self.workdir / 'stderr.txt'

    # names ---------------------------------------------------------------------------------
    def topic(self, name: str) -> str:
        """``~/name`` of the node -> its absolute name; ``name`` without ``~/`` is in the ns."""
        if name.startswith('~/'):
            return f'{self.namespace}/{NODE_NAME}/{name[2:]}'
        return f'{self.namespace}/{name}'

    # life cycle ----------------------------------------------------------------------------
    def command_line(self) -> list[str]:
        cmd = [
            sys.executable,
            '-m',
            'linkage_ros.node',
            '--ros-args',
            '-r',
            f'__ns:={self.namespace}',
        ]
        if self.params:
            pfile = self.workdir / 'params.yaml'
            pfile.write_text(
                yaml.safe_dump({f'{self.namespace}/{NODE_NAME}': {'ros__parameters': self.params}})
            )
            cmd += ['--params-file', str(pfile)]
        return cmd + self.args

    def start(self) -> NodeProcess:
        self._out = open(self.stdout_path, 'wb')  # noqa: SIM115 (lives with the process)
        self._err = open(self.stderr_path, 'wb')  # noqa: SIM115 (lives with the process)
        self.proc = subprocess.Popen(
            self.command_line(),
            env=ros_env(self.domain_id),
            stdout=self._out,
            stderr=self._err,
            cwd=str(REPO),
        )
        return self

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def wait(self, timeout: float) -> int:
        """Wait for the process to end by itself; its exit code."""
        assert self.proc is not None
        code = self.proc.wait(timeout=timeout)
        self._close_files()
        return code

    def stop(self, sig: int = signal.SIGINT, timeout: float = 10.0) -> int | None:
        """Signal, wait, and kill on timeout. Returns the exit code (None if it had to be
        killed)."""
        if self.proc is None:
            return None
        code = self.proc.poll()
        if code is None:
            self.proc.send_signal(sig)
            try:
                code = self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(timeout=timeout)
                code = None
        self._close_files()
        return code

    def _close_files(self):
        for f in (getattr(self, '_out', None), getattr(self, '_err', None)):
            if f is not None and not f.closed:
                f.close()

    def stdout(self) -> str:
        return self.stdout_path.read_text(errors='replace') if self.stdout_path.exists() else ''

    def stderr(self) -> str:
        return self.stderr_path.read_text(errors='replace') if self.stderr_path.exists() else ''

    def output(self) -> str:
        return self.stdout() + self.stderr()


class Collector:
    """Messages received on one topic, in arrival order."""

    def __init__(self, harness: RosHarness, msg_type, topic: str):
        self.topic = topic
        self.messages: list = []
        self.sub = harness.node.create_subscription(msg_type, topic, self.messages.append, QOS)

    def clear(self):
        self.messages.clear()

    def __len__(self):
        return len(self.messages)

    @property
    def last(self):
        return self.messages[-1]


class RosHarness:
    """The test side: one rclpy Context, node and executor on ``domain_id``."""

    def __init__(self, domain_id: int, name: str = 'linkage_test'):
        self.domain_id = domain_id
        self._saved = {
            k: os.environ.get(k) for k in ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'ROS_LOCALHOST_ONLY')
        }
        os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
        os.environ.pop('ROS_LOCALHOST_ONLY', None)
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node(f'{name}_{os.getpid()}', context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)
        for k, v in self._saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v

    # endpoints -----------------------------------------------------------------------------
    def publisher(self, msg_type, topic: str):
        return self.node.create_publisher(msg_type, topic, QOS)

    def collector(self, msg_type, topic: str) -> Collector:
        return Collector(self, msg_type, topic)

    # waiting -------------------------------------------------------------------------------
    def spin_until(
        self, pred: Callable[[], bool], timeout: float, process: NodeProcess | None = None
    ) -> bool:
        """Spin until ``pred()`` is true (True) or ``timeout`` s pass (False). Raises if the node
        process died meanwhile."""
        end = time.monotonic() + timeout
        while True:
            if pred():
                return True
            if process is not None and not process.alive():
                raise RuntimeError(
                    f'node process exited with {process.proc.returncode}:\n'
                    f'{process.output()[-3000:]}'
                )
            left = end - time.monotonic()
            if left <= 0:
                return False
            self.executor.spin_once(timeout_sec=min(0.05, left))

    def spin_for(self, seconds: float):
        """Keep receiving for ``seconds`` (a bounded quiet window: proving nothing arrives)."""
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self.executor.spin_once(timeout_sec=min(0.05, left))

    def wait_for_discovery(
        self,
        publishers=(),
        collectors=(),
        timeout: float = 20.0,
        process: NodeProcess | None = None,
    ):
        """Until every publisher has a matched subscription and every collector a matched
        publisher."""

        def matched():
            return all(p.get_subscription_count() > 0 for p in publishers) and all(
                c.sub.get_publisher_count() > 0 for c in collectors
            )

        if not self.spin_until(matched, timeout, process):
            missing = [p.topic_name for p in publishers if p.get_subscription_count() == 0] + [
                c.topic for c in collectors if c.sub.get_publisher_count() == 0
            ]
            raise TimeoutError(f'no match within {timeout} s on {missing}')

    def publish(self, publisher, msg, ack_timeout: float | None = None):
        """Publish; with ``ack_timeout``, also wait until every matched reader acknowledged the
        sample.

        Fast DDS readers acknowledge on the writer's heartbeat (every 3 s by default), so an
        acknowledged publish can take that long: request/answer exchanges wait for the answer
        instead, which proves delivery as well.
        """
        publisher.publish(msg)
        if ack_timeout is not None and not publisher.wait_for_all_acked(
            Duration(seconds=ack_timeout)
        ):
            raise TimeoutError(f'{publisher.topic_name}: sample not acknowledged')
