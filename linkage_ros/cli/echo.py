"""Print the messages of a topic of the running graph, without the ros2 CLI.

    linkage echo TOPIC [--count N] [--wait S] [--json]

The topic's type is read from the graph (it must be there, with a publisher or a subscription,
within --wait seconds) and the subscription matches the publishers' QoS (a latched topic's last
message is printed too).
Each message is printed as a YAML document (`---` between them, as `ros2 topic echo` does: a
byte field such as DiagnosticStatus.level as its number), or with --json as one JSON object per
line. It stops after --count messages or on Ctrl-C.

Exit status: 0; 2 a usage error (TOPIC not in the graph, a type not installed).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys

import yaml

from .common import OK, UsageError
from .ros_graph import (
    DEFAULT_WAIT,
    message_class,
    plain,
    ros_session,
    seconds,
    spin_until,
    subscription_qos,
)
from .ros_graph import topic_types as graph_topic_types


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = 'Print the messages of a topic (no ros2 CLI needed).'
    p.epilog = (__doc__ or '').split('\n', 2)[2].rstrip() + '\n'
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument('topic', metavar='TOPIC')
    p.add_argument('--count', type=int, metavar='N', help='stop after N messages')
    p.add_argument(
        '--wait',
        type=seconds,
        default=DEFAULT_WAIT,
        metavar='S',
        help=f'wait up to S seconds for TOPIC to appear: a publisher or a subscription of it '
        f'(default {DEFAULT_WAIT:g})',
    )
    p.add_argument('--json', action='store_true', help='one JSON object per line')


def run(args) -> int:
    if args.count is not None and args.count < 1:
        raise UsageError(f'--count must be >= 1 (got {args.count})')
    seen = [0]
    stop: list[int] = []

    def show(msg) -> None:
        data = plain(msg)
        if args.json:
            print(json.dumps(data), flush=True)
        else:
            print(yaml.safe_dump(data, sort_keys=False).rstrip() + '\n---', flush=True)
        seen[0] += 1

    with ros_session('linkage_echo') as node:
        ((topic, kind),) = graph_topic_types(node, [args.topic], args.wait).items()
        node.create_subscription(message_class(kind), topic, show, subscription_qos(node, topic))
        previous = signal.signal(signal.SIGINT, lambda number, frame: stop.append(number))
        try:
            spin_until(
                node, lambda: bool(stop) or (args.count is not None and seen[0] >= args.count), None
            )
        finally:
            signal.signal(signal.SIGINT, previous)
    if stop:
        print(f'linkage echo: {seen[0]} message(s)', file=sys.stderr)
    return OK
