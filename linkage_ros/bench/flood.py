"""A flood of requests at a node, from a process of its own (bench helper).

    python -m linkage_ros.bench.flood --topic /ns/linkage_node/target --kind huge \\
        --rate 100 --seconds 4 --out sent.json

Kinds: on ``~/target``, 'new_sets' names a new, unknown set of names every time (each used to
compile a solver and push a cached one out), 'huge' is a message with 10^5 names (2 MB
serialised); on ``~/trajectory``, 'trajectory' is a 10^4-point trajectory of the four-bar's
crank (a valid plan, seconds of solving each). The flood waits for the node's subscription,
writes ``ready`` on stdout, publishes at ``rate`` Hz (an absolute schedule) for ``seconds``
and writes how many it sent to ``--out``. It runs apart from the driver so that publishing
2 MB messages does not hold up the commands the driver sends and times.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

from .settings import FloodKind

#: the kinds of flood and the node topic each goes to
KINDS = {
    FloodKind.NEW_SETS: 'target',
    FloodKind.HUGE: 'target',
    FloodKind.TRAJECTORY: 'trajectory',
}
#: the points of a 'trajectory' flood request
TRAJECTORY_POINTS = 10_000


def payload(kind: FloodKind) -> tuple[Any, bytes | None]:
    """(message type, the serialised request sent every time; None: a new one each time)."""
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    if kind is FloodKind.TRAJECTORY:
        plan = JointTrajectory(joint_names=['crank'])
        plan.points = [
            JointTrajectoryPoint(positions=[1.0 + 0.001 * k]) for k in range(TRAJECTORY_POINTS)
        ]
        for k, point in enumerate(plan.points):
            sec, nanosec = divmod((k + 1) * 1_000_000, 1_000_000_000)
            point.time_from_start.sec, point.time_from_start.nanosec = sec, nanosec
        return JointTrajectory, serialize_message(plan)
    if kind is FloodKind.HUGE:
        big = JointState()
        big.name = [f'n{k}' for k in range(10**5)]
        big.position = [0.5] * len(big.name)
        return JointState, serialize_message(big)
    return JointState, None


def new_set(j: int) -> Any:
    from sensor_msgs.msg import JointState

    return JointState(name=[f'flood_{j}_a', f'flood_{j}_b'], position=[0.1, 0.2])


def run(topic: str, kind: FloodKind, rate: float, seconds: float, out: Path) -> int:
    import rclpy
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    msg_type, raw = payload(kind)
    rclpy.init()
    node = rclpy.create_node(f'linkage_bench_flood_{os.getpid()}')
    qos = QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        history=HistoryPolicy.KEEP_LAST,
        depth=1000,
        durability=DurabilityPolicy.VOLATILE,
    )
    pub = node.create_publisher(msg_type, topic, qos)
    sent = 0
    try:
        t_end = time.monotonic() + 20.0
        while pub.get_subscription_count() < 1:
            if time.monotonic() > t_end:
                print(f'no subscriber on {topic}', file=sys.stderr)
                return 1
            rclpy.spin_once(node, timeout_sec=0.05)
        print('ready', flush=True)
        t0 = time.perf_counter()
        n = max(1, int(round(rate * seconds)))
        while sent < n:
            due = t0 + sent / rate
            now = time.perf_counter()
            if now < due:
                time.sleep(min(due - now, 0.01))
                continue
            pub.publish(raw if raw is not None else new_set(sent))
            sent += 1
        out.write_text(json.dumps({'sent': sent, 'seconds': time.perf_counter() - t0}))
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description='flood a linkage_node (bench helper)')
    parser.add_argument('--topic', required=True)
    parser.add_argument('--kind', required=True, choices=sorted(KINDS))
    parser.add_argument('--rate', type=float, required=True, help='requests per second')
    parser.add_argument('--seconds', type=float, required=True)
    parser.add_argument('--out', type=Path, required=True, help='JSON file: how many were sent')
    opts = parser.parse_args(argv)
    return run(opts.topic, FloodKind(opts.kind), opts.rate, opts.seconds, opts.out)


if __name__ == '__main__':
    sys.exit(main())
