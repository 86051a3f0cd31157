#!/usr/bin/env python3
"""A bare rclpy JointState relay: the baseline the node's latency is measured against.

Subscribes ``~/command`` (sensor_msgs/JointState) and publishes every message unchanged on
``joint_states``, with the node's QoS (reliable, keep last 10, volatile), so the topic layout
and transport match ``linkage_node`` exactly and only the work done per message differs:

    python bench/relay_node.py --ros-args -r __ns:=/relay
    # /relay/relay_node/command  ->  /relay/joint_states

``linkage bench`` starts it as a separate process (see linkage_ros/bench.py).
"""
import sys

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, history=HistoryPolicy.KEEP_LAST, depth=10,
                 durability=DurabilityPolicy.VOLATILE)


class Relay(Node):
    def __init__(self):
        super().__init__('relay_node')
        self.pub = self.create_publisher(JointState, 'joint_states', QOS)
        self.create_subscription(JointState, '~/command', self.pub.publish, QOS)


def main(args=None) -> int:
    rclpy.init(args=args)
    node = None
    try:
        node = Relay()
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
