"""Get or set a parameter of a running node, without the ros2 CLI.

    linkage param get NODE NAME
    linkage param set NODE NAME VALUE
    linkage param list NODE

NODE is the node's name with its namespace (`/linkage_node`, `/robot/linkage_node`; a name
without `/` is in the root namespace). VALUE is read as YAML, as `ros2 param set` reads it:
`true`, `5`, `5.0`, `[a, b]`; anything else YAML reads (a mapping, a date, a list of mixed
kinds, `-`) is sent as the text itself. It goes through rclpy's AsyncParameterClient, the
node's own parameter services, so the node's checks apply: a refused value prints the node's
reason.

Exit status: 0 done; 1 the node refused the value; 2 a usage error (no such node within
--wait seconds, an unknown parameter).
"""

from __future__ import annotations

import argparse
import json
import re
from typing import Any

import yaml

from .common import OK, REFUSED, UsageError
from .process import say
from .ros_graph import (
    DEFAULT_WAIT,
    WAIT_TOLD_S,
    plain,
    ros_session,
    say_waiting,
    seconds,
    spin_until,
)

#: numbers YAML 1.1 reads as strings (an exponent without a dot or a sign: 1e1, 1.0e1, -2E-3)
_YAML_TEXT_NUMBER = re.compile(r'[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)[eE][+-]?[0-9]+')


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = 'Get, set or list the parameters of a running node (no ros2 CLI needed).'
    p.epilog = (__doc__ or '').split('\n', 2)[2].rstrip() + '\n'
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument('action', choices=('get', 'set', 'list'))
    p.add_argument('node', metavar='NODE', help='the node, e.g. /linkage_node')
    p.add_argument('name', metavar='NAME', nargs='?', help='the parameter (get, set)')
    p.add_argument('value', metavar='VALUE', nargs='?', help='the value to set (YAML)')
    p.add_argument(
        '--wait',
        type=seconds,
        default=DEFAULT_WAIT,
        metavar='S',
        help=f'wait up to S seconds for the node (default {DEFAULT_WAIT:g})',
    )


def run(args) -> int:
    from rclpy.parameter import Parameter, parameter_value_to_python
    from rclpy.parameter_client import AsyncParameterClient

    if args.action in ('get', 'set') and args.name is None:
        raise UsageError(f'param {args.action} needs NAME')
    if (args.action == 'set') != (args.value is not None):
        raise UsageError('VALUE goes with param set only')
    value = None if args.value is None else parameter_value(args.value)  # (before any wait)
    node_name = args.node if args.node.startswith('/') else f'/{args.node}'
    _check_node_name(node_name)
    with ros_session('linkage_param') as node:
        client = AsyncParameterClient(node, node_name)
        ready = spin_until(node, client.services_are_ready, min(WAIT_TOLD_S, args.wait))
        if not ready and args.wait > WAIT_TOLD_S:
            say_waiting(f'node {node_name}', args.wait)
            ready = spin_until(node, client.services_are_ready, args.wait - WAIT_TOLD_S)
        if not ready:
            nodes = sorted(
                f'{ns.rstrip("/")}/{n}' for n, ns in node.get_node_names_and_namespaces()
            )
            seen = ', '.join(n for n in nodes if n != '/linkage_param') or 'none'
            raise UsageError(
                f'no node {node_name} answered within {args.wait:g} s (nodes seen: {seen})'
            )

        def call(future):
            spin_until(node, future.done, args.wait)
            if not future.done():
                raise UsageError(f'{node_name} did not answer within {args.wait:g} s')
            return future.result()

        if args.action == 'list':
            for name in sorted(call(client.list_parameters()).result.names):
                say(name)
            return OK
        values = call(client.get_parameters([args.name])).values
        if not values or values[0].type == 0:  # none, or PARAMETER_NOT_SET
            # (rclpy's refusal of a set says 'Invalid access to undeclared parameter(s): []')
            raise UsageError(f'{node_name} has no parameter {args.name!r}')
        if args.action == 'get':
            value = plain(parameter_value_to_python(values[0]))
            say(json.dumps(value) if isinstance(value, list) else value)
            return OK
        (result,) = call(client.set_parameters([Parameter(args.name, value=value)])).results
        if not result.successful:
            say(f'linkage param: {node_name} refused {args.name}: {result.reason}')
            return REFUSED
        say(f'{node_name}: {args.name} = {args.value}')
        return OK


def _check_node_name(node_name: str) -> None:
    """UsageError where ``node_name`` cannot name a node's parameter services (`/linkage_node/`,
    `//n`, `/ünï` were rclpy's InvalidServiceNameException tracebacks: an adversary)."""
    from rclpy.exceptions import InvalidServiceNameException
    from rclpy.validate_full_topic_name import validate_full_topic_name

    if len(node_name) > 1 and node_name.endswith('/'):
        raise UsageError(f"NODE {node_name!r} is not a node name: it ends with '/'")
    try:
        validate_full_topic_name(f'{node_name}/get_parameters', is_service=True)
    except InvalidServiceNameException as exc:
        why = str(exc).splitlines()[0].split(': ', 1)[-1].rstrip(':')
        raise UsageError(f'NODE {node_name!r} is not a node name: {why}') from None


def parameter_value(text: str) -> bool | int | float | str | list:
    """VALUE as `ros2 param set` reads it (ros2param's get_parameter_value): YAML's bool, int,
    float or string, or a list of one kind of them; anything else the text itself (YAML reads
    `-` as [None], `2026-01-01` as a date: rclpy has no such parameter type, and raised)."""
    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        return text
    if isinstance(value, str) and _YAML_TEXT_NUMBER.fullmatch(text.strip()):
        return float(value)  # YAML 1.1 reads 1e1 (no dot) as text: a number is meant
    if isinstance(value, bool | int | float | str):
        return _in_int64(value, text)
    if isinstance(value, list) and value:
        for kind in (bool, int, float, str):  # (exact types: a bool is an int, and 1 no float)
            if all(type(v) is kind for v in value):
                return [_in_int64(v, text) for v in value]
    return text


#: a parameter's integers are 64-bit (rcl_interfaces' int64)
_INT64 = range(-(2**63), 2**63)


def _in_int64(value: Any, text: str) -> Any:
    """``value`` where it is no integer beyond 64 bits (rclpy raised a SystemError there: an
    adversary's find); UsageError otherwise."""
    if type(value) is int and value not in _INT64:
        raise UsageError(f"VALUE {text!r}: {value} is beyond a parameter's 64-bit integers")
    return value
