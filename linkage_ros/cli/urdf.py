"""Write the scene as a URDF tree for robot_state_publisher and RViz.

    linkage urdf SCENE [--prefix P] [--frame-id F] [-o FILE]

The joint names are the names linkage_node publishes on joint_states (with the same --prefix as
the node's ``prefix`` parameter), so robot_state_publisher fed by the node puts every link and
point frame where the solver says. The root link is the node's frame_id (the scene's, or
--frame-id as given to the node); every link is a frame named after it and every point P a frame
point_P, prefixed. Loop-closing joints are left out of the tree and listed in a comment. Without
-o the URDF goes to stdout, as a value rcl reads whole from the command line:
--ros-args -p robot_description:="$(linkage urdf four_bar)".

--prefix: ASCII letters, digits and _ . - / only, no '--', no leading '/' (the node's prefix
parameter takes the same).

Exit status: 0 written; 2 a usage error (a prefix or frame id that cannot name frames) or a
scene the URDF cannot name (a frame_id or names that would name two frames: a link named
point_P beside a point P) or draw (a structure that does not assemble with its stated
dimensions), one line on stderr.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from ..core.errors import LinkageError
from ..core.urdf import name_error, prefix_error, urdf_document
from .common import (
    DESCRIPTION_SUFFIXES,
    USAGE_ERROR,
    UsageError,
    add_scene_argument,
    file_name,
    load_mechanism,
    write_text_output,
)

PROG = 'linkage urdf'


def urdf_argv(
    scene: str, prefix: str = '', frame_id: str = '', program: Sequence[str] = ('linkage',)
) -> list[str]:
    """The command line of ``linkage urdf`` as an argument list (the launch file runs it so):
    a scene path with spaces or quotes stays one argument, where a command string split on
    spaces (launch's Command substitution) cut it apart. An empty frame_id: the scene's."""
    return [
        *program,
        'urdf',
        f'--prefix={prefix}',
        *([f'--frame-id={frame_id}'] if frame_id else []),
        '--',
        scene,
    ]


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = "Write the scene as a URDF tree (joint names = the node's joint_states)."
    p.epilog = __doc__.split('\n', 2)[2].rstrip() + '\n'
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    add_scene_argument(p, descriptions=False)  # (a robot description is refused: run())
    p.add_argument(
        '--prefix',
        default='',
        help="prepended to every joint and frame name except the root (the node's prefix)",
    )
    p.add_argument('--frame-id', default=None, help="root frame (default: the scene's frame_id)")
    p.add_argument(
        '-o', '--output', type=file_name, metavar='FILE', help='write here (default: stdout)'
    )


def _check_assembles(mech) -> None:
    """A structure (0 DOF) whose stated dimensions do not close has no pose to write (its
    drawing is not its shape): refused with the miss its solve reports."""
    if mech.dof != 0 or mech.actuators:
        return
    from ..core.solver import Solver

    r = Solver(mech).solve({}, commit=False)
    if not r.success:
        raise UsageError(f'the structure does not assemble, so it has no pose: {r.reason}')


def run(args: argparse.Namespace) -> int:
    try:
        why = prefix_error(args.prefix)
        if why:
            raise UsageError(f'--prefix {why}')
        why = name_error(args.frame_id) if args.frame_id is not None else None
        if why:
            raise UsageError(f'--frame-id {why}')
        if args.scene.lower().endswith(DESCRIPTION_SUFFIXES):
            # refused before it is read: its import would ask for options urdf does not take
            from ..core.urdf import DESCRIPTION_REFUSAL

            raise UsageError(f'{args.scene}: {DESCRIPTION_REFUSAL}')
        mech, scene_file = load_mechanism(args.scene, args.dimension)
        _check_assembles(mech)
        text = urdf_document(mech, prefix=args.prefix, frame_id=args.frame_id)
    except (UsageError, LinkageError) as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return USAGE_ERROR
    return write_text_output(PROG, text, args.output, [scene_file])
