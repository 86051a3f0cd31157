"""Write a robot description (URDF, SDF) as an editable scene file.

    linkage import DESCRIPTION [--closures FILE] [--actuated NAME ...] [--dimension NAME=VALUE]
                               [-o scene.yaml]

The scene is the general form (docs/SCENES.md) of the description's closed chain, assembled as
every other command assembles it, in the description's names: links, points (a joint's pin is
the point named after the joint), actuators, limits. Its ``joint_coordinates`` key keeps the
description's own joint names and values, so the scene file takes the same commands and
targets and publishes the same joint_states as the description (tested to 1e-12). Edit it
like any scene; a comment header names the description and the closure file it came from.

Without -o the scene goes to stdout; with -o FILE it is written whole or not at all (a failed
write leaves no partial file, and an existing FILE unchanged).

Exit status: 0 written; 2 a usage error (a path that is no description, a file that cannot be
written) or a description that cannot be imported (no closure, actuated joints that do not match
its degrees of freedom, a chain that cannot close, ...), one line on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from ..core.errors import LinkageError
from .common import (
    USAGE_ERROR,
    UsageError,
    add_description_arguments,
    dimension_argument,
    dimension_overrides,
    file_name,
    print_notes,
    write_text_output,
)

PROG = 'linkage import'


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        'Write a robot description (URDF, SDF) as an editable scene file that keeps its joint '
        'names and values.'
    )
    p.epilog = (__doc__ or '').split('\n', 2)[2].rstrip() + '\n'
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument(
        'description',
        metavar='DESCRIPTION',
        help='robot description file (.urdf, .sdf, .xml; xacro expanded)',
    )
    add_description_arguments(p)
    p.add_argument(
        '--dimension',
        action='append',
        default=[],
        type=dimension_argument,
        metavar='NAME=VALUE',
        help="a dimension stated in the scene, used exactly (m): LINK.P-Q in the scene's names "
        '(repeatable; see docs/SCENES.md)',
    )
    p.add_argument(
        '-o', '--output', type=file_name, metavar='FILE', help='write here (default: stdout)'
    )


def scene_text(
    description: str,
    closures: str | None = None,
    actuated: Sequence[str] = (),
    dimensions: Sequence[tuple[str, float]] = (),
) -> tuple[str, tuple[str, ...]]:
    """The scene file's text for ``description`` and the notes of its import."""
    from ..core.description import import_description, is_description
    from ..core.model.joint_map_io import joint_map_to_dict

    if not is_description(description):
        raise UsageError(
            f'{description}: not a robot description (.urdf, .sdf or .xml; a scene file is '
            'used as it is)'
        )
    if not Path(description).exists():
        raise UsageError(f'{description}: robot description not found')
    imported = import_description(
        description,
        closures,
        list(actuated) or None,
        dimensions=dimension_overrides(dimensions),
    )
    data: dict[str, Any] = dict(imported.scene)
    data['joint_coordinates'] = joint_map_to_dict(imported.joint_map)
    head = [
        f'# linkage_ros scene imported by `linkage import` from {_quoted(description)}',
        '# closures: '
        + (_quoted(closures) if closures else 'as the description states them (no side file)'),
        f'# actuated: {", ".join(imported.actuated)}',
        *(f'# note: {_one_line(n)}' for n in imported.notes),
        "# joint_coordinates: the description's joint names and values (commands, targets and",
        '# joint_states use them); keep it to publish for the description, drop it to publish',
        "# the scene's own joints. The points are the assembled reference pose (m).",
    ]
    body = yaml.dump(data, Dumper=_Dumper, sort_keys=False, width=100)
    return '\n'.join(head) + '\n' + body, imported.notes


class _Dumper(yaml.SafeDumper):
    """Block style, but a list of numbers or names on one line ([x, y], a link's points)."""


def _list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flat = all(isinstance(v, str | int | float | bool) or v is None for v in data)
    return dumper.represent_sequence('tag:yaml.org,2002:seq', data, flow_style=flat)


_Dumper.add_representer(list, _list)


def _quoted(path: str) -> str:
    """A path on one comment line, quoted as JSON when it has anything unusual in it."""
    return path if path.isprintable() and path.strip() == path else json.dumps(path)


def _one_line(text: str) -> str:
    return ' '.join(text.split())


def run(args: argparse.Namespace) -> int:
    try:
        text, notes = scene_text(args.description, args.closures, args.actuated, args.dimension)
        print_notes(notes)
    except (UsageError, LinkageError) as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return USAGE_ERROR
    read = [args.description] + ([args.closures] if args.closures else [])
    return write_text_output(PROG, text, args.output, read)


def main(argv: Sequence[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m linkage_ros.cli.importing ...``."""
    from .standalone import standalone_main

    return standalone_main(PROG, add_arguments, run, argv)


if __name__ == '__main__':
    sys.exit(main())
