"""``linkage bag INPUT... --out-dir DIR``: many bags in one run, on every core or a Dask cluster.

Each bag is one task (fleet_task.analyse_bag) with the run's options; the tasks run one after
the other (``--jobs 1``), in a local process pool (``--jobs N``, default: the machine's cores)
or on a Dask distributed cluster (``--scheduler ADDRESS``: dask.distributed's Client, imported
only then). A bag is solved from its own start in every case, so its outputs are the same
wherever it ran. One tqdm bar on stderr follows the fleet (bags done, messages read, rate, ETA),
and below it each bag being analysed has its own (one line per local worker; not for a Dask
cluster, whose workers have no terminal).
At the end ``summary.csv`` and ``summary.json`` (one row per bag) are written to DIR.

Exit status: 0 every bag analysed; 1 some bag had no request answered: every one refused,
or none on the topics given (and none failed);
2 unusable options or inputs (nothing run); 3 some bags failed (their rows say why; the others
are complete).
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import json
import os
import sys
import time
import uuid
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from ..cli.common import file_name
from ..cli.process import Terminated, say, terminate_raises
from ..outputs import name_refusal, text_cell
from .common import BagError
from .fleet_inputs import FORMATS, SUMMARY_NAMES, BagTask, find_bags
from .fleet_task import (
    SUMMARY_FIELDS,
    BagOptions,
    BagRow,
    BagStatus,
    analyse_bag,
    bag_fingerprint,
    finished_row,
    options_fingerprint,
    pool_worker_init,
    remove_outputs,
    stale_outputs,
)

ALL_DONE, SOME_REFUSED, SOME_FAILED = 0, 1, 3


def add_fleet_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of a fleet run (``linkage bag`` registers them beside its own)."""
    g = parser.add_argument_group('many bags (docs/FLEET.md)')
    g.add_argument(
        '--out-dir',
        type=file_name,
        metavar='DIR',
        default=None,
        help='analyse every bag of the inputs; outputs go to DIR/<bag path relative to its '
        'input folder (a glob: its folders before the first wildcard)>.<format>, beside '
        'summary.csv and summary.json',
    )
    g.add_argument(
        '--format',
        action='append',
        choices=FORMATS,
        default=[],
        help='an output format per bag (repeatable; default csv): csv, parquet, a result '
        'bag in mcap or sqlite3 storage, or the plot of --plot as png or svg',
    )
    g.add_argument(
        '--jobs',
        type=int,
        default=None,
        metavar='N',
        help="bags analysed at once in local processes (default: the machine's cores)",
    )
    g.add_argument(
        '--scheduler',
        metavar='ADDRESS',
        default=None,
        help='run the bags on this Dask distributed scheduler (e.g. tcp://host:8786); its '
        'workers need linkage_ros installed and the bag and output paths',
    )
    g.add_argument(
        '--resume',
        action='store_true',
        help='skip the bags whose outputs in DIR are complete (an earlier run of the same '
        'command), redo the others',
    )


# ---- preparing -----------------------------------------------------------------------------


def _prepare(args: argparse.Namespace) -> tuple[BagOptions, list[BagTask]]:
    from .options import bag_options, check_options

    if args.out:
        raise BagError('--out and --out-dir: give one (--out for one bag, --out-dir for many)')
    if args.plot:
        raise BagError(
            '--plot names one file (for one bag); with --out-dir give --format png (or svg): '
            "each bag's plot beside its other outputs"
        )
    if args.jobs is not None and args.jobs < 1:
        raise BagError(f'--jobs must be >= 1 (got {args.jobs})')
    if args.jobs is not None and args.scheduler:
        raise BagError("--jobs and --scheduler: the cluster's workers set how many bags run")
    if args.out_format is not None:
        raise BagError(
            '--out-format names the storage of the one bag --out writes; with --out-dir give '
            "--format sqlite3 (or mcap): each bag's output bag beside its other outputs"
        )
    formats = list(dict.fromkeys(args.format or ['csv']))
    out_dir = Path(args.out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise BagError(f'--out-dir {out_dir}: is not a folder')
    earlier: list[Path] = []
    tasks = find_bags(args.input, out_dir.resolve(), earlier)
    if earlier:
        print(
            f'note: {len(earlier)} result bag(s) of an earlier run left out ({earlier[0]}'
            + (', ...' if len(earlier) > 1 else '')
            + ': a NAME.mcap or NAME.sqlite3 folder beside its NAME.done.json); name one itself '
            'to analyse it',
            file=sys.stderr,
        )
    check_options(args)
    opts = bag_options(args, formats, str(out_dir.resolve()))
    reserved = {str(Path(opts.out_dir, n)) for n in SUMMARY_NAMES}
    for t in tasks:
        for fmt in formats:
            if str(t.output(opts.out_dir, fmt)) in reserved:
                raise BagError(f'bag {t.source}: its output would overwrite {t.name}.{fmt}')
        for owned in t.owned_names():
            too_long = name_refusal(Path(opts.out_dir, owned))
            if too_long:
                raise BagError(f'bag {t.source}: its output {owned}: {too_long}')
        if Path(opts.out_dir).resolve() in Path(t.source).parents:
            raise BagError(f'bag {t.source} is inside --out-dir {out_dir}: choose another folder')
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BagError(f'--out-dir {out_dir}: cannot create it ({exc.strerror or exc})') from None
    if not os.access(out_dir, os.W_OK | os.X_OK):
        raise BagError(
            f'--out-dir {out_dir}: is not writable (no write permission, or a read-only file '
            'system)'
        )
    return opts, tasks


def _plan(
    tasks: list[BagTask], opts: BagOptions, resume: bool
) -> tuple[list[tuple[int, BagTask, str]], dict[int, BagRow]]:
    """The bags to analyse (index, task, fingerprint) and, with ``resume``, the rows of those
    already complete. Without ``resume`` an earlier run's outputs are a usage error (nothing
    is overwritten); with it, an unfinished bag's leftovers are removed before it is redone."""
    digest = options_fingerprint(opts)
    todo, done = [], {}
    for i, t in enumerate(tasks):
        fp = bag_fingerprint(t, digest)
        row = finished_row(t, opts.out_dir, fp) if resume else None
        if row is not None:
            done[i] = row
            continue
        stale = stale_outputs(t, opts)
        if stale and not resume:
            raise BagError(
                f'--out-dir {opts.out_dir} holds outputs of an earlier run ({stale[0]}): '
                '--resume finishes that run, or choose an empty folder'
            )
        remove_outputs(stale)
        todo.append((i, t, fp))
    summaries = [n for n in SUMMARY_NAMES if Path(opts.out_dir, n).exists()]
    if summaries and not resume:  # (an earlier run's, of other bags: its record of them)
        raise BagError(
            f'--out-dir {opts.out_dir} holds outputs of an earlier run ({summaries[0]}): '
            '--resume finishes that run, or choose an empty folder'
        )
    return todo, done


# ---- running: serial, local processes, Dask -------------------------------------------------


def _failed(task: BagTask, why: str) -> BagRow:
    return BagRow(bag=task.name, source=task.source, status=BagStatus.FAILED, reason=why)


def _serial(
    todo: list[tuple[int, BagTask, str]], opts: BagOptions, bars: bool
) -> Iterator[tuple[int, BagRow]]:
    for i, t, fp in todo:  # each bag's progress on the line below the fleet's
        yield i, analyse_bag(t, opts, fp, 1 if bars else 0)


def _pool(
    todo: list[tuple[int, BagTask, str]], opts: BagOptions, jobs: int, bars: bool
) -> Iterator[tuple[int, BagRow]]:
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait

    # fork: a worker starts in milliseconds with the package already imported (no threads run
    # in this process before the pool starts); spawn where there is no fork
    method = 'fork' if 'fork' in mp.get_all_start_methods() else 'spawn'
    ctx = mp.get_context(method)
    # each worker takes a terminal line of its own below the fleet's bar for its bags' bars
    lines = ctx.Value('i', 0)
    ex = ProcessPoolExecutor(
        max_workers=jobs,
        mp_context=ctx,
        initializer=pool_worker_init,
        initargs=(lines if bars else None,),
    )
    # one bag per worker in flight, the next submitted as one ends: on Ctrl-C no bag waits in
    # the pool's queue to be started anyway (all submitted at once, the queue's bags ran to the
    # end before the exit). The first ones now, before the progress bar exists: they fork the
    # workers, and the bar's monitor thread must not be forked
    pending = iter(todo)
    futures: dict[Future[BagRow], tuple[int, BagTask]] = {}

    def submit_next() -> None:
        for i, t, fp in pending:
            futures[ex.submit(analyse_bag, t, opts, fp)] = (i, t)
            return

    for _ in range(jobs):
        submit_next()

    def results() -> Iterator[tuple[int, BagRow]]:
        try:
            while futures:
                done, _ = wait(list(futures), return_when=FIRST_COMPLETED)
                for f in done:
                    i, t = futures.pop(f)
                    submit_next()
                    try:
                        yield i, f.result()
                    except Exception as exc:  # noqa: BLE001 - the worker died (killed, OOM)
                        why = f'the worker process was lost ({type(exc).__name__}: {exc})'
                        yield i, _failed(t, why)
        finally:
            ex.shutdown(wait=True, cancel_futures=True)

    return results()


def _dask(
    todo: list[tuple[int, BagTask, str]], opts: BagOptions, address: str
) -> Iterator[tuple[int, BagRow]]:
    from dask.distributed import Client, as_completed

    try:
        client = Client(address, timeout='20s')
    except Exception as exc:  # noqa: BLE001 - unreachable, refused, not a scheduler
        raise BagError(f'--scheduler {address}: cannot connect ({exc})') from None
    run = uuid.uuid4().hex[:12]
    try:
        futures = {
            client.submit(analyse_bag, t, opts, fp, 0, key=f'linkage-bag-{run}-{i}', pure=False): (
                i,
                t,
            )
            for i, t, fp in todo
        }
        for f in as_completed(list(futures)):
            i, t = futures[f]
            try:
                yield i, f.result()
            except Exception as exc:  # noqa: BLE001 - e.g. the task's workers kept dying
                yield i, _failed(t, f'the cluster could not run it ({type(exc).__name__}: {exc})')
    finally:
        client.close()


# ---- summary -------------------------------------------------------------------------------


def _csv_value(v: Any) -> str:
    if v is None:
        return ''
    if isinstance(v, bool):
        return 'true' if v else 'false'
    if isinstance(v, float):
        return repr(v)
    return text_cell(str(v))


def summary_csv_text(rows: Sequence[BagRow]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator='\n')
    w.writerow(SUMMARY_FIELDS)
    for r in rows:
        d = r.as_dict()
        w.writerow([_csv_value(d[k]) for k in SUMMARY_FIELDS])
    return buf.getvalue()


def totals(rows: Sequence[BagRow]) -> dict[str, int]:
    return {
        'bags': len(rows),
        'ok': sum(r.status is BagStatus.OK for r in rows),
        'all_refused': sum(r.status is BagStatus.REFUSED for r in rows),
        'failed': sum(r.status is BagStatus.FAILED for r in rows),
        'resumed': sum(r.resumed for r in rows),
        'messages': sum(r.messages for r in rows),
        'answered': sum(r.answered for r in rows),
        'refused': sum(r.refused for r in rows),
        'missing': sum(r.missing for r in rows),
    }


def write_summary(out_dir: str, rows: Sequence[BagRow]) -> list[Path]:
    from ..outputs import written_whole

    csv_path, json_path = (Path(out_dir, n) for n in SUMMARY_NAMES)
    with written_whole(csv_path) as tmp:
        tmp.write_text(summary_csv_text(rows))
    doc = {'totals': totals(rows), 'bags': [r.as_dict() for r in rows]}
    with written_whole(json_path) as tmp:
        tmp.write_text(json.dumps(doc, indent=1, allow_nan=False) + '\n')
    return [csv_path, json_path]


# ---- the command ---------------------------------------------------------------------------


def run_fleet(args: argparse.Namespace) -> int:
    """``linkage bag ... --out-dir DIR``; returns the exit status (module docstring)."""
    from tqdm import tqdm

    t0 = time.perf_counter()
    opts, tasks = _prepare(args)
    # the folders under --out-dir before the run: a failed bag's empty ones are removed only
    # where the run made them (a folder the user made stays, an adversary's find)
    existed = {Path(root) for root, _, _ in os.walk(opts.out_dir)}
    todo, done = _plan(tasks, opts, args.resume)
    rows: dict[int, BagRow] = dict(done)
    if done:
        say(f'linkage bag: {len(done)} bag(s) complete already, skipped (--resume)')
    jobs = args.jobs if args.jobs is not None else (os.cpu_count() or 1)
    enabled = not args.no_progress and sys.stderr.isatty()
    if args.scheduler:  # the cluster's workers have no terminal: the fleet's bar alone
        where = f'the Dask cluster at {args.scheduler}'
        results = _dask(todo, opts, args.scheduler)
    elif jobs > 1 and len(todo) > 1:
        jobs = min(jobs, len(todo))
        where = f'{jobs} local processes'
        results = _pool(todo, opts, jobs, enabled)
    else:
        where = 'this process'
        results = _serial(todo, opts, enabled)
    read = 0  # messages read (BagRow.messages: --state-completion's skipped ones too)
    with (
        _workers_stopped_on_sigterm(),
        tqdm(
            total=len(todo),
            desc='bags',
            unit='bag',
            file=sys.stderr,
            disable=not enabled,
            dynamic_ncols=True,
        ) as bar,
    ):
        for i, row in results:
            rows[i] = row
            read += row.messages
            bar.update(1)
            rate = read / max(time.perf_counter() - t0, 1e-9)
            bar.set_postfix_str(f'{read:,} messages, {rate:,.0f}/s')
            if row.status is BagStatus.FAILED:
                bar.write(f'linkage bag: {row.bag}: failed: {row.reason}', file=sys.stderr)
    ordered = [rows[i] for i in range(len(tasks))]
    failed = [t for t, r in zip(tasks, ordered) if r.status is BagStatus.FAILED]
    _prune_empty(opts.out_dir, failed, existed)
    written = write_summary(opts.out_dir, ordered)
    _print_summary(ordered, where, len(todo), time.perf_counter() - t0, written)
    t = totals(ordered)
    if t['failed']:
        return SOME_FAILED
    return SOME_REFUSED if t['all_refused'] else ALL_DONE


@contextlib.contextmanager
def _workers_stopped_on_sigterm() -> Iterator[None]:
    """A SIGTERM to this process alone (a supervisor's stop, `kill PID`) ends the run as
    Ctrl-C does, its worker processes stopped first: they had run their bags on and then sat
    idle, orphaned (an adversary). Their staging files go with the next --resume, as a killed
    run's do. (The workers keep SIGTERM's default: pool_worker_init.)"""
    import multiprocessing as mp

    try:
        with terminate_raises():
            yield
    except Terminated:
        for child in mp.active_children():
            child.terminate()
        raise


def _prune_empty(out_dir: str, failed: list[BagTask], existed: set[Path]) -> None:
    """The folders under ``out_dir`` this run made for failed bags' outputs (not in
    ``existed``) that hold nothing: removed (a failed bag leaves no output: FLEET.md). Once
    every bag is done, so that no other bag's write races the removal."""
    top = Path(out_dir)
    for task in failed:
        folder = task.output(out_dir, 'csv').parent
        while folder != top and top in folder.parents and folder not in existed:
            try:
                folder.rmdir()  # (only an empty one)
            except OSError:
                break
            folder = folder.parent


def _print_summary(
    rows: list[BagRow], where: str, ran: int, seconds: float, written: list[Path]
) -> None:
    t = totals(rows)
    lines = [
        f'linkage bag: {t["bags"]} bag(s): {t["ok"]} ok, {t["all_refused"]} with no request '
        f'answered, {t["failed"]} failed'
        + (f', {t["resumed"]} complete already' if t['resumed'] else ''),
        f'  {t["messages"]:,} message(s): answered {t["answered"]:,}, refused {t["refused"]:,}'
        + (f', missing {t["missing"]:,}' if t['missing'] else ''),
        f'  {ran} bag(s) analysed on {where} in {seconds:.2f} s',
    ]
    for r in rows:
        if r.status is not BagStatus.OK and not r.resumed:
            lines.append(f'  {r.bag}: {r.status}: {r.reason}')
    lines += [f'  wrote {p}' for p in written]
    say('\n'.join(lines))
