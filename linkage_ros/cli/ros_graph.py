"""What ``linkage record``, ``linkage echo`` and ``linkage param`` share: a short-lived rclpy
session, a topic's type and QoS resolved from the running graph, a message class by its type
name, and a message as plain data for printing. rclpy is imported here only (the other
subcommands start without it)."""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from .common import UsageError

#: how long to wait for a topic or node to appear in the graph (s) unless told
DEFAULT_WAIT = 10.0


def seconds(text: str) -> float:
    """An argparse type for --wait and --duration: a finite number of seconds, 0 or more
    (nan, inf and -1 were taken: nan and inf waited forever, -1 said 'within -1 s')."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected seconds, got {text!r}') from None
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(
            f'must be a finite number of seconds, 0 or more (got {text})'
        )
    return value + 0.0  # (-0 is 0)


#: after this long (s) without the topic or node, the wait is said on stderr
WAIT_TOLD_S = 2.0


@contextmanager
def ros_session(name: str) -> Iterator[Any]:
    """An rclpy node ``name`` in a context of its own, shut down on leaving (also on Ctrl-C).
    The signal handlers stay Python's, so Ctrl-C is a KeyboardInterrupt the command handles."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(name, context=context, start_parameter_services=False)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def say_waiting(what: str, wait: float) -> None:
    """Tell on stderr that the command waits for ``what`` (said once a wait has lasted
    WAIT_TOLD_S: discovery takes a moment; beyond it, a misspelt name would be silence)."""
    print(f'waiting for {what} (up to {wait:g} s: --wait)', file=sys.stderr, flush=True)


def spin_until(node: Any, done: Callable[[], bool], seconds: float | None) -> bool:
    """Spin ``node`` until ``done()`` or ``seconds`` pass (None: no limit); whether done."""
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    end = None if seconds is None else time.monotonic() + seconds
    try:
        while not done():
            if end is not None and time.monotonic() >= end:
                return False
            executor.spin_once(timeout_sec=0.05)
        return True
    finally:
        executor.remove_node(node)
        executor.shutdown()


def topic_types(node: Any, topics: Sequence[str], wait: float) -> dict[str, str]:
    """Each topic's type ('sensor_msgs/msg/JointState') from the graph, waiting up to ``wait``
    s for all to be in it (a publisher or a subscription: the node's ~/command is there before
    anyone publishes on it); UsageError naming a topic not in the graph, or two types."""
    names = [t if t.startswith('/') else f'/{t}' for t in topics]
    start = time.monotonic()
    end, told = start + wait, False
    while True:
        graph = dict(node.get_topic_names_and_types())
        missing = [t for t in names if t not in graph]
        if not missing or time.monotonic() >= end:
            break
        if not told and time.monotonic() - start >= WAIT_TOLD_S and wait > WAIT_TOLD_S:
            told = True
            say_waiting(f'{", ".join(missing)} to appear in the ROS graph', wait)
        time.sleep(0.05)
    if missing:
        seen = ', '.join(sorted(graph)) or 'none'
        raise UsageError(
            f'no publisher or subscription of {", ".join(missing)} appeared within {wait:g} s '
            f'(same ROS_DOMAIN_ID and discovery range? topics seen: {seen})'
        )
    out = {}
    for t in names:
        kinds = graph[t]
        if len(kinds) != 1:
            raise UsageError(f'{t} is published with {len(kinds)} types {kinds}: cannot record')
        out[t] = kinds[0]
    return out


def message_class(type_name: str) -> Any:
    """'sensor_msgs/msg/JointState' -> the class (its package's Python module, imported)."""
    pkg, kind, name = (type_name.split('/') + ['', ''])[:3]
    try:
        return getattr(importlib.import_module(f'{pkg}.{kind}'), name)
    except (ImportError, AttributeError, ValueError):
        raise UsageError(
            f'message type {type_name} is not installed here (its Python package {pkg})'
        ) from None


def subscription_qos(node: Any, topic: str, depth: int = 100) -> Any:
    """A QoS that matches every publisher of ``topic``: reliable unless one is best effort,
    transient local (a latched topic's last message) only if all are."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    infos = node.get_publishers_info_by_topic(topic)
    best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
    latched = bool(infos) and all(
        i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos
    )
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def plain(value: Any) -> Any:
    """A message as plain data (dicts, lists, numbers, strings), as ``ros2 topic echo`` shows
    it: a byte field (DiagnosticStatus.level) as its number, arrays as lists."""
    if hasattr(value, 'get_fields_and_field_types'):
        return {f: plain(getattr(value, f)) for f in value.get_fields_and_field_types()}
    if isinstance(value, bytes):
        return value[0] if len(value) == 1 else list(value)
    if isinstance(value, str | bool | int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    if hasattr(value, 'tolist'):  # numpy arrays, array.array
        return [plain(v) for v in value.tolist()]
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    return str(value)
