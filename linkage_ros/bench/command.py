"""``linkage bench``: arguments and the run."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..cli.common import UsageError
from ..outputs import folder_refusal, input_refusal, written_whole
from .collect import CASES, collect
from .fleet import render_fleet
from .report import met_text, render_markdown, save_plot, write_report
from .settings import FULL, QUICK, SCENES, Sizes, log

# =============================================================================================
# command line
# =============================================================================================


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = (
        'Benchmark the solver settings (speed vs accuracy against a 50-digit '
        'reference), vectorised throughput, Newton vs scipy, and the node '
        'latency vs a bare rclpy relay.'
    )
    parser.add_argument(
        '--quick',
        action='store_true',
        help='tiny sizes (a smoke run of the machinery: about 15 s with --no-node, 10 s with '
        '--no-node --no-fleet, 1-2 min with the node cases on a 2-core machine); numbers are '
        'not meaningful',
    )
    parser.add_argument(
        '--write',
        metavar='MD',
        help='write the report below the marker line of this markdown file '
        '(e.g. docs/BENCHMARKS.md) and the plot next to it',
    )
    parser.add_argument(
        '--plot',
        metavar='PNG',
        help='error-vs-time plot (default with --write: bench_tradeoff.png next '
        'to the markdown file)',
    )
    parser.add_argument(
        '--no-node',
        action='store_true',
        help='skip the node latency / rate measurement (no ROS processes)',
    )
    parser.add_argument(
        '--no-fleet',
        action='store_true',
        help='skip the fleet analysis (many bags: serial, --jobs 2, a Dask LocalCluster)',
    )
    parser.add_argument(
        '--fleet-only',
        action='store_true',
        help='measure the fleet analysis alone and print its section (no --write)',
    )
    parser.add_argument('--json', metavar='FILE', help='also dump the raw results as JSON')
    parser.add_argument(
        '--render',
        metavar='JSON',
        help='do not measure: render the report (and plot) from the --json dump of an earlier run',
    )
    parser.add_argument(
        '--cases',
        default=','.join(CASES),
        help='comma-separated measurements to run (default: all of '
        f'{",".join(CASES)}); a partial run is for looking at, not for --write',
    )
    parser.add_argument(
        '--scenes',
        default=None,
        help=f'comma-separated scenes (default {",".join(SCENES)}); given, they are also the '
        'scenes of the every-output node case (default: every packaged scene, --quick: '
        'four_bar and excavator)',
    )


def _outputs_refusal(args: argparse.Namespace) -> None:
    """The output files refused before any measurement (a run is minutes long: a --json to a
    folder that does not exist lost a whole run at its end, a new user): UsageError."""
    for option, path in (('--json', args.json), ('--plot', args.plot), ('--write', args.write)):
        if path is None:
            continue
        why = folder_refusal(path) or (
            input_refusal(path, [args.render]) if getattr(args, 'render', None) else None
        )
        if why:
            raise UsageError(f'{option} {path}: {why}')


def _dump(path: str) -> dict[str, Any]:
    """An earlier run's --json dump (UsageError naming what is wrong with it)."""
    try:
        report = json.loads(Path(path).read_text(encoding='utf-8'))
    except OSError as exc:
        raise UsageError(f'--render {path}: cannot be read ({exc.strerror or exc})') from None
    except UnicodeDecodeError:
        raise UsageError(f'--render {path}: not JSON (not UTF-8 text)') from None
    except ValueError as exc:
        raise UsageError(f'--render {path}: not JSON ({exc})') from None
    missing = (
        [k for k in ('machine', 'targets', 'settings', 'seconds') if k not in report]
        if (isinstance(report, dict))
        else ['a JSON object']
    )
    if missing:
        raise UsageError(
            f'--render {path}: not a linkage bench --json dump (it lacks {", ".join(missing)})'
        )
    try:  # (what a run writes, read through: a part of one fails here, before any output)
        render_markdown(report, str(report.get('command', '')), None)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
        raise UsageError(
            f'--render {path}: not a whole linkage bench --json dump ({type(exc).__name__}: {exc})'
        ) from None
    return report


def run(args) -> int:
    _outputs_refusal(args)
    sizes = QUICK if args.quick else FULL
    scenes = [s.strip() for s in (args.scenes or ','.join(SCENES)).split(',') if s.strip()]
    if args.scenes is not None:
        sizes = dataclasses.replace(sizes, node_all_scenes=tuple(scenes))
    if args.fleet_only:
        return _fleet_only(args, sizes)
    if args.render:
        report = _dump(args.render)
        command = report.get('command', 'linkage bench')
    else:
        cases = [c.strip() for c in args.cases.split(',') if c.strip()]
        if args.no_fleet:
            cases = [c for c in cases if c != 'fleet']
        unknown = sorted(set(cases) - set(CASES))
        if unknown:
            raise UsageError(f'unknown case(s) {unknown}; the cases: {list(CASES)}')
        if args.write and set(cases) | {'fleet'} != set(CASES):
            raise UsageError('--write takes a whole run (no --cases; --no-fleet allowed)')
        report = collect(sizes, scenes, node=not args.no_node, cases=cases)
        command = (
            'linkage bench'
            + (' --quick' if args.quick else '')
            + (f' --write {args.write}' if args.write else '')
            + (' --no-node' if args.no_node else '')
            + (' --no-fleet' if args.no_fleet else '')
            + (f' --cases {",".join(cases)}' if set(cases) | {'fleet'} != set(CASES) else '')
            + (f' --scenes {",".join(scenes)}' if args.scenes is not None else '')
        )
        report['command'] = command
    plot = (
        Path(args.plot)
        if args.plot
        else (Path(args.write).parent / 'bench_tradeoff.png' if args.write else None)
    )
    plot_rel = None
    if plot is not None:
        save_plot(report, plot)
        plot_rel = os.path.relpath(plot, Path(args.write).parent) if args.write else str(plot)
    body = render_markdown(report, command, plot_rel)
    if args.write:
        write_report(Path(args.write), body)
        log(f'wrote {args.write}' + (f' and {plot}' if plot else ''))
    else:
        print(body)
    if args.json:
        with written_whole(args.json) as tmp:
            tmp.write_text(json.dumps(report, indent=1, default=float))
    for t in report['targets']:
        print(f'{met_text(t["met"]).strip("*"):8} {t["target"]}: {t["measured"]}')
    print(f'linkage bench: {report["seconds"]:.0f} s')
    return 0


def _fleet_only(args: argparse.Namespace, sizes: Sizes) -> int:
    """``--fleet-only``: the fleet measurement, its section and targets on stdout."""
    if args.write or args.render or args.no_fleet:
        log('--fleet-only goes without --write, --render and --no-fleet')
        return 2
    report = collect(sizes, (), node=False, cases=['fleet'])
    m = report['machine']
    print(
        f'machine: {m["nproc"]} CPU(s) ({m["cpu"]}); load average before {m["loadavg"]}, '
        f'after {report["loadavg_end"]}; other processes used '
        + (
            'n/a'
            if report['other_cpu_cores'] is None
            else f'{report["other_cpu_cores"]:.2f} cores on average'
        )
    )
    print(render_fleet(report))
    if args.json:
        with written_whole(args.json) as tmp:
            tmp.write_text(json.dumps(report, indent=1, default=float))
    for t in report['targets']:
        print(f'{met_text(t["met"]).strip("*"):8} {t["target"]}: {t["measured"]}')
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m linkage_ros.bench ...``: the same as ``linkage bench ...``."""
    from ..cli.standalone import standalone_main

    return standalone_main('linkage bench', add_arguments, run, argv)
