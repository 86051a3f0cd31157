"""The ``linkage`` parser, the subcommands registered from their modules, and the entry points."""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence
from typing import Any

from ..core.tolerances import NEWTON_TOL
from ..heap import keep_large_buffers
from .arguments import branch_value, signs_as_values
from .check import cmd_check
from .common import USAGE_ERROR, KnownAction, OneLineErrorParser, add_scene_argument, file_name
from .process import run_command
from .solve import cmd_solve
from .sweep import cmd_sweep

# ---- parser ------------------------------------------------------------------------------------

KNOWN_HELP = """\
knowns (in command-line order; with `sweep` that order is the grid order):
  --set NAME=VALUE          an actuator value (rad or m; or with a unit: 30deg, 16mm)
  --target NAME=VALUE       a joint value, a link's angle (from +x), an actuator, or one
                            coordinate of a point, P.x or P.y (m): inverse solve
  --target-point NAME=X,Y   a point's position (m): inverse solve
  --set and --target may be combined: the knowns are all the names given, and they must fix
  every degree of freedom (e.g. one actuator and one joint angle of the 2-DOF plagiograph).
  --set alone for some actuators holds the others at their drawn values (linkage check
  prints them), as the node holds an actuator a command leaves out.
  For a robot description the names and values are its own joints' (--set an actuated joint,
  --target any joint it can set), as the node takes them; the answer's inputs and joints too.
"""

SOLVE_EPILOG = (
    KNOWN_HELP
    + """
assembly mode: an inverse solve (default --branch reference) is answered in the reference pose's
assembly mode within the actuator limits, as a node (branch continuous, its default) answers its
first target: where the actuator takes the drawing through a toggle, both signs of that circuit
are its mode. A target only another mode reaches is refused, unless --any-mode: naming
that mode where the closed form places the target; where Newton places it (a single point
coordinate), saying that --any-mode searches the other modes (a multi-start search, run
only when asked). (`linkage sweep --branch reference` and a node with branch:=reference hold the
drawn signs themselves: their commands are solved in them.)

exit status: 0 solved; 1 refused (status "error" with a reason; with --all-branches: no mode
closes); 2 usage error.

examples:
  linkage solve four_bar --set crank=0.5
  linkage solve four_bar --set crank=30deg --all-branches --json
  linkage solve four_bar --target rocker=1.9 --json
  linkage solve plagiograph --target-point D=0.125,0.185
"""
)

SWEEP_EPILOG = (
    KNOWN_HELP
    + """
ranges: NAME=START:STOP:COUNT (COUNT evenly spaced values, both ends included) and, for points,
NAME=X0,Y0:X1,Y1:COUNT (a straight segment). Several ranges make a grid: the first range on the
command line varies slowest, the last fastest (nested loops in command-line order). A fixed
NAME=VALUE stays constant. The solver keeps its state between lines, so --branch continuous
(default) follows the assembly mode along the sweep.

output: one line per grid point, never dropped: refused inputs are error lines (status "error"
and the reason). --json prints JSON lines: the solve schema plus "index" and "command" (the
commanded values). A summary "N command(s), K ok, E error(s)" goes to stderr.

csv: --csv FILE writes one row per command with every actuator and joint value (rad, m), e.g. the
coordinated actuator motion of a --target-point path, to feed a controller.

An inverse sweep (--target, --target-point) with --branch continuous answers each line as a
node answers a stream of targets: in the assembly mode the mechanism is in, refused where only
the other mode reaches the target.

exit status: 0 when the sweep ran (even if some lines are errors; --strict makes any error line
exit 1); 2 usage error.

examples:
  linkage sweep four_bar --set crank=0:6.283185307:73
  linkage sweep plagiograph --set theta_A=0.2:0.5:11 --set theta_C=1.2:1.5:11 --json
"""
)

CHECK_EPILOG = """\
prints links (and their points), joints (type, point, parent, child), link and joint counts,
Kutzbach DOF 3(n-1)-2j against the actuator count, the Grashof class of a one-loop four-link
scene driven by a crank (4R: s + l against p + q; 3R-1P: lmin + e against lmax) with the
inequality and which ground-pivoted links turn fully, each input's range (null / "unlimited"
for an unlimited side), and how the default solve is planned: the closed-form dyad steps, the
links they place, the links left to the Newton solver and the solver mode.
For a mechanism with one actuator, "motion" sweeps it over its range (a full turn when it turns
fully): each rocker's swing and each ground slider's stroke with the input values at their
extremes, the time ratio (slower / faster stroke of a fully turning crank), and each RRR dyad's
transmission angle extremes (JSON: motion.outputs, motion.transmission_angle). Warnings (JSON:
warnings) name a reference pose drawn at a toggle.
A scene that does not load (e.g. DOF != actuators) is an error: exit 2.
"""

MAIN_EPILOG = """\
SCENE is a scene file, the name of a packaged scene (e.g. four_bar), or a robot description
(.urdf, .sdf, .xml; with --closures FILE for a side file stating its loops, --actuated NAME for
its inputs): requests and answers then use the description's own joint names and values
(docs/ROBOT_DESCRIPTIONS.md).
exit status: 0 ok, 1 solve refused, 2 usage error, 130 interrupted (Ctrl-C).
`linkage COMMAND --help` for details.
"""

#: subcommand -> module defining ``add_arguments(parser)`` and ``run(args) -> int``; a module that
#: does not import is left out (the reason shows in ``linkage --help``).
EXTERNAL_COMMANDS = {
    'range': 'linkage_ros.cli.range',
    'bag': 'linkage_ros.bag',
    'bench': 'linkage_ros.bench',
    'urdf': 'linkage_ros.cli.urdf',
    'import': 'linkage_ros.cli.importing',
    # wheels-only equivalents of ros2 bag record / topic echo / param (rclpy imported on run)
    'record': 'linkage_ros.cli.record',
    'echo': 'linkage_ros.cli.echo',
    'param': 'linkage_ros.cli.param',
}


def _add_solve_options(p, default_branch: str, ranges: bool):
    add_scene_argument(p)
    g = p.add_argument_group('knowns')
    r = '[:STOP:COUNT]' if ranges else ''
    g.add_argument(
        '--set',
        action=KnownAction,
        metavar=f'NAME=VALUE{r}',
        dest='knowns',
        help='actuator value' + (' or range' if ranges else '') + ' (repeatable)',
    )
    g.add_argument(
        '--target',
        action=KnownAction,
        metavar=f'NAME=VALUE{r}',
        dest='knowns',
        help='joint / link angle / actuator / point coordinate (P.x, P.y: m) to reach: '
        'inverse solve (repeatable)',
    )
    g.add_argument(
        '--target-point',
        action=KnownAction,
        dest='knowns',
        metavar='NAME=X,Y' + ('[:X1,Y1:COUNT]' if ranges else ''),
        help='point position to reach: inverse solve (repeatable)',
    )
    s = p.add_argument_group('solver')
    s.add_argument(
        '--branch',
        type=branch_value,
        default=default_branch,
        help="assembly mode: 'continuous', 'reference', one sign per branching "
        "dyad such as '+-', or for a scene Newton places 'J+' / 'J-' (the sign of its loop "
        f"Jacobian's determinant; default {default_branch})",
    )
    s.add_argument(
        '--solver',
        choices=('auto', 'closed_form', 'newton'),
        default=None,
        help="solver (default: the scene's, normally auto)",
    )
    s.add_argument(
        '--tol',
        type=float,
        default=NEWTON_TOL,
        help=f'Newton tolerance, relative to the length scale (default {NEWTON_TOL:g})',
    )
    s.add_argument('--max-iter', type=int, default=50, help='Newton iteration cap (default 50)')
    p.add_argument('--json', action='store_true', help='machine-readable output')


def _load_external() -> tuple[dict[str, Any], dict[str, str]]:
    """Import the plug-in subcommand modules; returns ({name: module}, {name: why not})."""
    ok, broken = {}, {}
    for name, modname in EXTERNAL_COMMANDS.items():
        try:
            mod = importlib.import_module(modname)
        except ModuleNotFoundError as exc:
            if exc.name is not None and modname.startswith(exc.name):
                continue  # not written / not installed: silently absent
            broken[name] = f'{type(exc).__name__}: {exc}'
            continue
        except Exception as exc:  # noqa: BLE001 - a broken plug-in must not break the CLI
            broken[name] = f'{type(exc).__name__}: {exc}'
            continue
        if not (
            callable(getattr(mod, 'add_arguments', None)) and callable(getattr(mod, 'run', None))
        ):
            broken[name] = f'{modname} lacks add_arguments(parser) / run(args)'
            continue
        ok[name] = mod
    return ok, broken


def build_parser() -> tuple[argparse.ArgumentParser, dict[str, str]]:
    external, broken = _load_external()
    epilog = MAIN_EPILOG + ''.join(f'unavailable: {k} ({v})\n' for k, v in broken.items())
    parser = OneLineErrorParser(
        prog='linkage',
        description='Solve, sweep and check planar linkage scenes.',
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest='command', metavar='COMMAND', parser_class=OneLineErrorParser)
    sub.required = True
    fmt = argparse.RawDescriptionHelpFormatter

    p = sub.add_parser(
        'solve',
        help='one forward or inverse position solve',
        description='Solve one configuration: forward from actuator values '
        '(--set) or inverse from targets (--target, --target-point).',
        epilog=SOLVE_EPILOG,
        formatter_class=fmt,
    )
    _add_solve_options(p, 'reference', ranges=False)
    p.add_argument(
        '--all-branches',
        action='store_true',
        help='every assembly mode of the command (ignores --branch): each sign combination '
        'of the dyad plan; where Newton places the mechanism, the solutions a search from '
        '128 starts finds, each labelled with its mode (a mode may have more than one: the '
        "roots either side of one coordinate's extreme), said to be possibly incomplete "
        '(JSON: modes_complete)',
    )
    p.add_argument(
        '--any-mode',
        action='store_true',
        help='inverse solve: accept a target that only another assembly mode than the '
        "reference pose's reaches (by default it is refused: naming that mode where the "
        'closed form places the target, else saying --any-mode searches the others)',
    )
    p.set_defaults(func=cmd_solve)

    p = sub.add_parser(
        'sweep',
        help='solve a range or grid of commands, one line each',
        description='Solve a range (or a grid of ranges) of commands, one output line per command.',
        epilog=SWEEP_EPILOG,
        formatter_class=fmt,
    )
    _add_solve_options(p, 'continuous', ranges=True)
    p.add_argument('--strict', action='store_true', help='exit 1 if any line is an error')
    p.add_argument(
        '--csv',
        type=file_name,
        metavar='FILE',
        help='also write the trajectory as CSV: index, status, reason, input.<actuator>... and '
        'joint.<joint>... (full precision; a refused row has its inputs, angles wrapped as answers '
        'give them, and no joints), written whole or not at all',
    )
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser(
        'check',
        help='links, joints, DOF, Grashof class, input ranges, solve plan',
        description='Check a scene and describe how it will be solved.',
        epilog=CHECK_EPILOG,
        formatter_class=fmt,
    )
    add_scene_argument(p)
    p.add_argument(
        '--solver',
        choices=('auto', 'closed_form', 'newton'),
        default=None,
        help="solver whose plan to describe (default: the scene's)",
    )
    p.add_argument('--json', action='store_true', help='machine-readable output')
    p.set_defaults(func=cmd_check)

    for name, mod in external.items():
        p = sub.add_parser(
            name,
            help=(mod.__doc__ or '').strip().splitlines()[0] if mod.__doc__ else None,
            formatter_class=fmt,
        )
        mod.add_arguments(p)
        p.set_defaults(func=mod.run)
    return parser, broken


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    # batches of 10^4 rows and more (sweep, bag, range, bench) make arrays of 100s of kB, which
    # glibc's defaults give back to the kernel and fault in again for each one (heap.py)
    keep_large_buffers()
    parser, broken = build_parser()
    if argv and argv[0] in broken:
        print(
            f'linkage: error: command {argv[0]!r} is unavailable: {broken[argv[0]]}',
            file=sys.stderr,
        )
        return USAGE_ERROR
    try:
        args = parser.parse_args(signs_as_values(argv))
    except SystemExit as exc:  # --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else USAGE_ERROR
    return run_command(f'linkage {args.command}', args.func, args)


if __name__ == '__main__':
    sys.exit(main())
