"""Record topics of the running graph into a rosbag2 (MCAP or sqlite3), without the ros2 CLI.

    linkage record TOPIC [TOPIC ...] -o BAG [--storage mcap|sqlite3] [--duration S] [--wait S]

Each topic's type is read from the graph (it must be there, with a publisher or a subscription,
within --wait seconds: the node's ~/command is, before anyone publishes on it); the
messages are written as received (serialized CDR, no decoding) with their receive time, by
rosbags, the library `linkage bag` reads with. The subscriptions match the publishers' QoS
(a latched topic's last message is recorded too); each publisher matched is reported on
stderr, and a topic's messages are recorded from then on. Recording stops on Ctrl-C or after
--duration seconds; either way the bag is closed and renamed into place: until then it is
written in a hidden `.BAG.PID.partial` folder beside BAG, so a run that fails leaves nothing
under BAG. An existing BAG is refused. A one-line summary goes to stderr.

Exit status: 0 recorded; 2 a usage error (BAG exists, a topic not in the graph, a type not
installed or not known to rosbags' Jazzy type store).
"""

from __future__ import annotations

import argparse
import os
import shutil
import signal
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..outputs import staging_name
from .common import OK, UsageError, file_name
from .ros_graph import (
    DEFAULT_WAIT,
    message_class,
    ros_session,
    seconds,
    spin_until,
    subscription_qos,
)
from .ros_graph import topic_types as graph_topic_types

PROG = 'linkage record'


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = 'Record topics of the running ROS graph into a rosbag2 (no ros2 CLI needed).'
    p.epilog = (__doc__ or '').split('\n', 2)[2].rstrip() + '\n'
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument('topics', metavar='TOPIC', nargs='+', help='topics to record')
    p.add_argument(
        '-o',
        '--output',
        type=file_name,
        metavar='BAG',
        required=True,
        help='the bag folder to write',
    )
    p.add_argument(
        '--storage',
        choices=('mcap', 'sqlite3'),
        default='mcap',
        help='storage format (default mcap)',
    )
    p.add_argument(
        '--duration', type=seconds, metavar='S', help='stop after S seconds (default: Ctrl-C)'
    )
    p.add_argument(
        '--wait',
        type=seconds,
        default=DEFAULT_WAIT,
        metavar='S',
        help=f'wait up to S seconds for every topic to be in the graph, published or subscribed '
        f'(default {DEFAULT_WAIT:g})',
    )


@dataclass
class _Counts:
    per_topic: dict[str, int] = field(default_factory=dict)

    @property
    def total(self) -> int:
        return sum(self.per_topic.values())


def run(args) -> int:
    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin
    from rosbags.typesys import Stores, get_typestore

    final = Path(args.output)
    if final.exists():
        raise UsageError(f'{final} exists: give a new BAG (a bag is never overwritten)')
    if args.duration is not None and not args.duration > 0:
        raise UsageError(f'--duration must be > 0 s (got {args.duration:g})')
    store = get_typestore(Stores.ROS2_JAZZY)
    plugin = StoragePlugin.MCAP if args.storage == 'mcap' else StoragePlugin.SQLITE3
    counts = _Counts()
    with ros_session('linkage_record') as node:
        types = graph_topic_types(node, args.topics, args.wait)
        for topic, kind in types.items():
            if kind not in store.types:
                raise UsageError(f'{topic}: type {kind} is not in the ROS 2 Jazzy type store')
            message_class(kind)  # installed: a subscription can be made
        stage = final.parent / staging_name(final.name)
        try:
            stage.mkdir()
        except OSError as exc:
            raise UsageError(f'cannot create {final}: {exc.strerror or exc}') from None
        try:
            writer = Writer(stage / final.name, version=9, storage_plugin=plugin)
            writer.open()
            try:
                _record(node, writer, store, types, counts, args.duration)
            finally:
                writer.close()
            os.replace(stage / final.name, final)
        finally:
            shutil.rmtree(stage, ignore_errors=True)
    per = ', '.join(f'{t} {n}' for t, n in counts.per_topic.items())
    print(f'{PROG}: {counts.total} message(s) -> {final} ({per})', file=sys.stderr)
    return OK


def _record(node, writer, store, types: dict[str, str], counts: _Counts, duration) -> None:
    """Subscribe (raw CDR) and write each message at its receive time until Ctrl-C or
    ``duration`` seconds."""
    from rclpy.event_handler import SubscriptionEventCallbacks

    clock = node.get_clock()
    subscriptions: list[Any] = []
    for topic, kind in types.items():
        conn = writer.add_connection(topic, kind, typestore=store)
        counts.per_topic[topic] = 0

        def write(data: bytes, conn=conn, topic=topic) -> None:
            writer.write(conn, clock.now().nanoseconds, data)
            counts.per_topic[topic] += 1

        def matched(status, topic=topic) -> None:
            # on stderr: which publishers are heard (a publisher joining later is recorded
            # from its match on; what it published before is not, unless it is latched)
            print(
                f'{PROG}: {topic}: {status.current_count} publisher(s) matched',
                file=sys.stderr,
                flush=True,
            )

        qos = subscription_qos(node, topic)
        events = SubscriptionEventCallbacks(matched=matched)
        subscriptions.append(
            node.create_subscription(
                message_class(kind), topic, write, qos, raw=True, event_callbacks=events
            )
        )
    print(
        f'{PROG}: recording {", ".join(types)} (Ctrl-C to stop)',
        file=sys.stderr,
        flush=True,
    )
    # Ctrl-C (and SIGTERM) end the recording between messages, never inside a write
    stop: list[int] = []
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig in handlers:
        signal.signal(sig, lambda number, frame: stop.append(number))
    try:
        spin_until(node, lambda: bool(stop), duration)
    finally:
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        for sub in subscriptions:
            node.destroy_subscription(sub)
