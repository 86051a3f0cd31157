"""``linkage bag``: arguments, the checks made before any work, and the run."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..cli.arguments import branch_value
from ..cli.common import UsageError, add_scene_argument, file_name
from ..cli.process import say
from ..core.errors import LinkageError
from ..core.tolerances import NEWTON_TOL
from ..outputs import folder_refusal, input_refusal, name_refusal
from .common import DEFAULT_OUT_FORMAT, BagError
from .fleet_inputs import bags_in
from .fleet_run import add_fleet_arguments
from .fleet_task import unanswered
from .options import bag_options, check_options
from .plans import plans_csv_path, plans_summary
from .plot import plot_format
from .progress import Progress, summary_text
from .reading import exc_text
from .replay import ReplayEngine
from .run_outputs import Output, OutputKind, RunOutputs

# ---- command line ------------------------------------------------------------------------------


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``linkage bag`` options (the CLI registers this module as the ``bag`` subcommand)."""
    parser.description = (
        'Solve every command recorded in a rosbag2 the way the node would and '
        'write a CSV and/or a result bag.'
    )
    parser.epilog = BAG_EPILOG
    parser.add_argument(
        'input',
        metavar='INPUT',
        nargs='+',
        help='rosbag2 folder (sqlite3 or mcap) or a single .mcap/.db3 file; with --out-dir '
        'several, and folders holding bags (searched recursively) or glob patterns',
    )
    add_scene_argument(parser, flag=True)
    parser.add_argument(
        '--command-topic',
        required=True,
        metavar='TOPIC',
        help='sensor_msgs/msg/JointState commands naming the actuators',
    )
    parser.add_argument(
        '--state-completion',
        action='store_true',
        help="read --command-topic as the node's joint_states_in reads a hardware JointState "
        "(a robot's recorded /joint_states): each message's values of the mechanism's inputs "
        'command it, its other joints are not read, and a message with none of the inputs is '
        'skipped (docs/TOPICS.md, State completion). The result bag answers as the node '
        'answers joint_states_in: joint_states without the inputs (the hardware publishes '
        "them), statuses with request 'joint_states_in'",
    )
    parser.add_argument(
        '--publish-inputs',
        action='store_true',
        help="with --state-completion: the result bag's joint_states carry the inputs too, as "
        "the node's publish_inputs parameter makes them (every joint of the chain)",
    )
    parser.add_argument(
        '--target-topic',
        metavar='TOPIC',
        default=None,
        help='sensor_msgs/msg/JointState targets naming joints, links or '
        "actuators (the node's ~/target: inverse kinematics)",
    )
    parser.add_argument(
        '--target-any-mode-topic',
        metavar='TOPIC',
        default=None,
        help="sensor_msgs/msg/JointState targets that may change the assembly mode (the node's "
        '~/target_any_mode), answered as the node answers them',
    )
    parser.add_argument(
        '--trajectory-topic',
        action='append',
        default=[],
        metavar='TOPIC',
        help="trajectory_msgs/msg/JointTrajectory requests (the node's ~/trajectory), answered "
        'at their place in bag time; may be given more than once',
    )
    parser.add_argument(
        '--path-topic',
        action='append',
        default=[],
        metavar='TOPIC',
        help="nav_msgs/msg/Path requests (the node's ~/target_path/<point>; the point is the "
        "topic's last name), answered like trajectories; may be given more than once",
    )
    parser.add_argument(
        '--frame-id',
        default='',
        metavar='FRAME',
        help="as the node's frame_id parameter in the run recorded (default: the scene's): "
        'the frame of the outputs, and the one requests in another frame are refused in',
    )
    parser.add_argument(
        '--target-point-hold',
        action='append',
        default=[],
        metavar='NAME',
        help="as the node's target_point_hold parameter: for a path on a mechanism with more "
        'than 2 DOF, these names keep their values (e.g. bucket); may be given more than once',
    )
    parser.add_argument(
        '--out',
        action='append',
        type=file_name,
        default=[],
        metavar='OUTPUT',
        help='one bag: *.csv for a table, else a new rosbag2 folder; may be given twice',
    )
    parser.add_argument(
        '--out-format',
        choices=('mcap', 'sqlite3'),
        default=None,  # (DEFAULT_OUT_FORMAT; None: not given, which --out-dir needs to know)
        help=f'storage of an output bag (default {DEFAULT_OUT_FORMAT})',
    )
    parser.add_argument(
        '--remap',
        action='append',
        default=[],
        metavar='FROM:=TO',
        help="rename an output bag's topic (the node's names by default: /joint_states, "
        '/linkage_node/points/<p>, /linkage_node/status, /linkage_node/solved_trajectory); '
        'repeatable',
    )
    parser.add_argument(
        '--solver',
        choices=('auto', 'closed_form', 'newton'),
        default=None,
        help="solver (default: the scene's)",
    )
    parser.add_argument(
        '--branch',
        type=branch_value,
        default='continuous',
        help="continuous (default, like the node), reference, or signs like '+-'",
    )
    parser.add_argument(
        '--tol',
        type=float,
        default=NEWTON_TOL,
        help=f'Newton tolerance relative to the length scale (default {NEWTON_TOL:g})',
    )
    parser.add_argument(
        '--max-iter', type=int, default=50, help='Newton iteration cap (default 50)'
    )
    parser.add_argument(
        '--plot',
        type=file_name,
        metavar='PNG',
        default=None,
        help='write coupler-point traces and input/joint curves to this image '
        '(format from the extension: png, svg, pdf, ...; PNG if none); with or without --out',
    )
    parser.add_argument(
        '--accept-missing',
        action='store_true',
        help='read a bag whose index counts more messages than it holds (a damaged or edited '
        'bag) instead of refusing it; the summary says how many are missing per topic',
    )
    add_fleet_arguments(parser)
    parser.add_argument(
        '--no-progress',
        action='store_true',
        help='no progress bar (it is shown only when stderr is a terminal)',
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m linkage_ros.bag ...``."""
    from ..cli.standalone import standalone_main

    return standalone_main('linkage bag', add_arguments, run, argv)


def run(args: argparse.Namespace) -> int:
    """Run ``linkage bag``; returns the exit status (0 done, 1 every request of the bag
    refused, 2 unusable input or options; with --out-dir 3 when some bags failed)."""
    try:
        if args.out_dir is not None:
            from .fleet_run import run_fleet

            return run_fleet(args)
        return _run(args)
    except (BagError, LinkageError, UsageError) as exc:
        print(f'linkage bag: error: {exc}', file=sys.stderr)
        return USAGE_ERROR


def _run(args) -> int:
    from .fleet_task import replay_input

    t_start = time.perf_counter()
    fleet_only = [
        opt
        for opt, given in (
            ('--format', args.format),
            ('--jobs', args.jobs is not None),
            ('--scheduler', args.scheduler),
            ('--resume', args.resume),
        )
        if given
    ]
    if fleet_only:
        raise BagError(f'{fleet_only[0]} goes with --out-dir (the outputs of a fleet run)')
    if len(args.input) != 1:
        raise BagError(
            f'{len(args.input)} inputs: several bags need --out-dir DIR (--out names the '
            'outputs of one bag)'
        )
    if not args.out and not args.plot:  # (a plot alone is an output too)
        raise BagError(
            'no output: give --out OUTPUT and/or --plot IMAGE (one bag) or --out-dir DIR (many)'
        )
    source = args.input[0]
    _one_bag(source)
    scene = check_options(args)
    mech = scene.mechanism
    outs = _check_outputs(args.out, args.plot, _input_files(source, scene.path))
    progress = Progress(enabled=not args.no_progress and sys.stderr.isatty())

    try:
        engine = ReplayEngine(
            mech, args.solver, args.tol, args.max_iter, args.branch, args.target_point_hold
        )
        marks: list[float] = []
        opts = bag_options(args)
        outputs = _run_outputs(outs, args, scene, opts)
        try:
            data, res, plans = replay_input(
                engine, mech, source, opts, progress, opts.frame(scene), marks, outputs
            )
            t_read, t_solve = marks[0], time.perf_counter()
            outputs.finish(data, res, progress)
        except BaseException:
            outputs.abort()
            raise
        t_end = time.perf_counter()
    finally:
        progress.clear()  # an error message starts on a line of its own
    summary_text(data, res, outs, args.plot, t_start, t_read, t_solve, t_end)
    for line in plans_summary(plans):
        say(line)
    for kind, path in outs:
        if kind is OutputKind.CSV and plans:
            say(f'  wrote {plans_csv_path(path)} (csv: the trajectories and paths)')
    why = unanswered(data, res, plans)
    if why is not None:
        print(f'linkage bag: {why}', file=sys.stderr)
        return ALL_REFUSED
    return OK


def _run_outputs(outs, args, scene, opts) -> RunOutputs:
    """One bag's --out files (a CSV's trajectories beside it) and --plot."""
    table = [
        Output(
            kind,
            Path(path),
            args.out_format or DEFAULT_OUT_FORMAT,
        )
        for kind, path in outs
    ]
    if args.plot:
        table.append(Output(OutputKind.PLOT, Path(args.plot)))
    csvs = [path for kind, path in outs if kind is OutputKind.CSV]
    return RunOutputs(
        table,
        scene.mechanism,
        opts.frame(scene),
        plans_csvs=[Path(plans_csv_path(p)) for p in csvs],
        remap=dict(opts.remap),
        publish_inputs=opts.publish_inputs,
        all_or_none=False,  # as before streaming: a finished --out stays when a later one fails
    )


def _resolved(path: Path, what: str) -> Path:
    """The absolute path with symlinks resolved; a symlink loop is a clear error."""
    try:
        return path.resolve()
    except (RuntimeError, OSError) as exc:  # Python < 3.13: RuntimeError on a loop
        raise BagError(f'{what}: cannot use this path ({exc_text(exc)})') from None


def _check_parent(path: Path, what: str) -> Path:
    full = _resolved(path, what)
    why = folder_refusal(full)
    if why:
        raise BagError(f'{what}: {why}')
    return full


def _one_bag(source: str) -> None:
    """A folder (no bag itself) holding one storage file is read as that bag; holding more
    bags below it too, it is refused (the others would be left out without a word)."""
    p = Path(source)
    if not p.is_dir() or (p / 'metadata.yaml').is_file():
        return
    found = bags_in(p)
    top = [bag for bag, _ in found if bag.parent == p]
    below = [name for bag, name in found if bag.parent != p]
    if len(top) == 1 and below:
        raise BagError(
            f'input {source}: a folder holding {top[0].name} and more bags below it '
            f'({below[0]}, ...): several bags need --out-dir DIR, or give one of them'
        )


#: --out names whose suffix says a file --out does not write (it would be a bag folder of
#: that name): what writes it instead
_NOT_A_BAG = {
    '.parquet': 'Parquet is written per bag with --out-dir DIR --format parquet',
    '.json': 'a JSON summary is written with --out-dir DIR (DIR/summary.json)',
    **dict.fromkeys(('.png', '.svg', '.pdf'), 'a plot is --plot FILE.png or .svg'),
}


def _input_files(source: str, scene: Any) -> list[Path]:
    """The files a bag run reads: the bag's (a folder's every file, metadata.yaml and its
    storage) and the scene's."""
    p = Path(source)
    files = [Path(str(scene))] if scene is not None else []
    with contextlib.suppress(OSError):
        files += [f for f in p.iterdir() if f.is_file()] if p.is_dir() else [p]
    return files


def _check_outputs(outs: list[str], plot: str | None, inputs: Sequence[Path] = ()):
    checked = []
    for path in [*outs, *([plot] if plot is not None else [])]:
        # (an output through a symlink to the recording or the scene replaced it: an adversary)
        why = input_refusal(path, inputs)
        if why:
            raise BagError(f'output {path}: {why}')
    for path in outs:
        p = Path(path)
        what = f'output {path}'
        too_long = name_refusal(p)  # (first: a path's own checks raise on it)
        if too_long:
            raise BagError(f'{what}: {too_long}')
        if p.suffix.lower() == '.csv':
            kind = OutputKind.CSV
            if p.is_dir():
                raise BagError(f'{what}: is a folder')
        elif p.suffix.lower() in _NOT_A_BAG:
            raise BagError(
                f'{what}: --out writes a CSV (*.csv) or a rosbag2 folder; '
                f'{_NOT_A_BAG[p.suffix.lower()]}'
            )
        else:
            kind = OutputKind.BAG
            if p.exists() or p.is_symlink():
                raise BagError(
                    f'{what}: exists already (an output bag must be a new folder; not overwriting)'
                )
        checked.append((kind, p, _check_parent(p, what)))
    if len({str(full) for _, _, full in checked}) != len(checked):
        raise BagError('the same --out path is given twice')
    # a command CSV's trajectories go beside it (out.trajectories.csv): not an --out of its own
    for kind, p, full in checked:
        if kind is not OutputKind.CSV:
            continue
        beside = Path(plans_csv_path(full))
        too_long = name_refusal(beside)
        if too_long:
            raise BagError(
                f'output {plans_csv_path(p)} (the trajectories and paths of --out {p}): {too_long}'
            )
        if any(beside == other for _, _, other in checked):
            raise BagError(
                f'output {plans_csv_path(p)}: is where the trajectories and paths of --out {p} '
                'are written; give the other output another name'
            )
        if beside.is_dir():
            raise BagError(
                f'output {plans_csv_path(p)} (the trajectories and paths of --out {p}): is a folder'
            )
    if plot is not None:
        what = f'--plot {plot}'
        too_long = name_refusal(plot)
        if too_long:
            raise BagError(f'{what}: {too_long}')
        full = _check_parent(Path(plot), what)
        if full.is_dir():
            raise BagError(f'{what}: is a folder')
        if any(full == out for _, _, out in checked):
            raise BagError(f'{what}: is also an --out path')
        plot_format(plot)
    return [(kind, p) for kind, p, _ in checked]


USAGE_ERROR, OK = 2, 0
#: no request of the bag answered: every one refused, or none read (the outputs are written)
ALL_REFUSED = 1


BAG_EPILOG = """\
outputs:
  OUTPUT.csv  one row per command (refused ones too): time (header stamp, s), receive_time
              (bag time, s), topic, input.<actuator>..., joint.<joint>..., velocity.<joint>...
              (when commands gave velocities: the node's answer to them), <point>.x,
              <point>.y (every point), residual, margin, branch, status (ok/error), reason
  OUTPUT      a new rosbag2 folder (--out-format mcap|sqlite3) with the node's topics:
              /joint_states, /linkage_node/points/<output point>, /linkage_node/status (one
              per command; ERROR with the reason); --remap FROM:=TO renames one

examples:
  linkage bag run1 --scene four_bar --command-topic /linkage_node/command --out run1.csv
  linkage bag run1.mcap --scene my.yaml --command-topic /cmd --target-topic /tgt \\
      --out answers --out answers.csv --plot run1.png

many bags (--out-dir DIR; docs/FLEET.md):
  linkage bag recordings/ 'more/*.mcap' --scene four_bar --command-topic /cmd \\
      --out-dir analysis --format parquet --format csv [--jobs N | --scheduler ADDRESS] [--resume]
  writes DIR/<bag path relative to its input folder>.<format> per bag, DIR/summary.csv and
  DIR/summary.json (one row per bag; a damaged bag fails alone, its row says why).

exit status: 0 done (refused commands are rows, not failures); 1 every request refused,
every message skipped by --state-completion, or no message on the topics given (the outputs
are written; a wrong --scene or topic?); 2 unusable input, output or options (missing file,
not a bag, missing topic, wrong type, truncated or corrupt bag); with --out-dir: 1 some bag
had no request answered (as above), 3 some bags failed (the others are complete).
"""
