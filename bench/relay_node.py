#!/usr/bin/env python3
"""A bare rclpy JointState relay: the baseline the node's latency is measured against.

Subscribes ``~/command`` (sensor_msgs/JointState) and publishes every message unchanged on
``joint_states``, with the node's QoS (reliable, keep last N, volatile; the subscription N = 10
as the node's default ``queue_depth``, or ``--depth N`` as the node's ``-p queue_depth:=N``; the
publisher 100 as the node's default ``output_depth``, or ``--output-depth N``), so the topic
layout and transport match ``linkage_node`` exactly and only the work done per message differs:

    python bench/relay_node.py [--depth N] [--output-depth N] --ros-args -r __ns:=/relay
    # /relay/relay_node/command  ->  /relay/joint_states

``linkage bench`` starts it as a separate process (see linkage_ros/bench.py).
"""

import argparse
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState


class Relay(Node):
    def __init__(self, depth: int = 10, output_depth: int = 100):
        super().__init__('relay_node')

        def qos(n: int) -> QoSProfile:
            return QoSProfile(
                reliability=ReliabilityPolicy.RELIABLE,
                history=HistoryPolicy.KEEP_LAST,
                depth=n,
                durability=DurabilityPolicy.VOLATILE,
            )

        self.pub = self.create_publisher(JointState, 'joint_states', qos(output_depth))
        self.create_subscription(JointState, '~/command', self.pub.publish, qos(depth))


def main(args=None) -> int:
    argv = sys.argv[1:] if args is None else list(args)
    cut = argv.index('--ros-args') if '--ros-args' in argv else len(argv)
    parser = argparse.ArgumentParser(description='bare rclpy JointState relay (benchmark baseline)')
    parser.add_argument(
        '--depth',
        type=int,
        default=10,
        help='history depth of the command subscription (keep last N; default 10)',
    )
    parser.add_argument(
        '--output-depth',
        type=int,
        default=100,
        help='history depth of joint_states (keep last N; default 100)',
    )
    opts = parser.parse_args(argv[:cut])
    for flag, n in (('--depth', opts.depth), ('--output-depth', opts.output_depth)):
        if n < 1:
            parser.error(f'{flag} must be >= 1 (got {n})')
    rclpy.init(args=[sys.argv[0]] + argv[cut:])
    node = None
    try:
        node = Relay(opts.depth, opts.output_depth)
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
