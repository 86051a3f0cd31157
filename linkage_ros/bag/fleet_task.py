"""One bag of a fleet run, start to finish: the task a local process or a Dask worker runs.

:func:`analyse_bag` solves one bag exactly as ``linkage bag`` does for a single bag (its own
engine from the reference pose: a bag's answers never depend on which bags ran before it in the
same process), writes its outputs under ``--out-dir`` and returns its summary row. Every failure
(a damaged bag, a missing topic, a full disk, even a bug) is that bag's row with the reason;
it never stops the others.

Completeness (``--resume``): each output is renamed into place only once whole, and after the
last of them a small manifest ``<name>.done.json`` is written (also whole, by rename). It holds
the summary row, the outputs and a fingerprint of what they were made from (the options, the
scene file's bytes, the bag's files' sizes and modification times). A bag counts as finished
when its manifest parses, its fingerprint matches this run's and every output it lists exists;
anything else (no manifest: the run stopped or the worker was lost before it) is redone.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import shutil
import time
from dataclasses import asdict, dataclass, field
from enum import StrEnum
from pathlib import Path, PurePosixPath
from typing import Any

import numpy as np

from ..heap import set_malloc_thresholds
from .common import BagError
from .fleet_inputs import BagTask
from .plans import PlanRequest, decoded_plans, path_point, plan_topics, read_plan_requests
from .progress import Progress
from .reading import Commands, exc_text, read_commands
from .results import Results
from .run_outputs import Output, OutputKind, RunOutputs
from .state_completion import completed_commands

#: manifest layout version (a manifest of another version is not trusted)
MANIFEST_VERSION = 1


class BagStatus(StrEnum):
    """A bag's outcome in the fleet summary (its value is what the summary and the manifest
    say)."""

    OK = 'ok'  # some command answered
    REFUSED = 'all refused'  # every request refused, or none read: exit status 1
    FAILED = 'failed'  # the bag could not be analysed: exit status 3


@dataclass(frozen=True)
class BagOptions:
    """What every bag of a run is solved and written with (plain data: pickled to workers)."""

    scene: str  # a path (absolute) or a packaged scene's name
    dimensions: tuple[tuple[str, float], ...]
    closures: str | None
    actuated: tuple[str, ...]
    command_topic: str
    target_topic: str | None
    trajectory_topics: tuple[str, ...]
    path_topics: tuple[str, ...]
    hold: tuple[str, ...]
    solver: str | None
    branch: str
    tol: float
    max_iter: int
    accept_missing: bool
    formats: tuple[str, ...]
    out_format: str  # storage of the single-bag --out bag (unused by --format)
    out_dir: str
    remap: tuple[tuple[str, str], ...] = ()  # output bag topic renames (--remap)
    #: the node's frame_id parameter in the run recorded (--frame-id); '' = the scene's
    frame_id: str = ''
    #: the command topic read as the node's joint_states_in (--state-completion)
    state_completion: bool = False
    #: with it, the result bag's joint_states carry the inputs too (--publish-inputs)
    publish_inputs: bool = False
    #: the node's ~/target_any_mode (--target-any-mode-topic): targets that may change the mode
    any_mode_topic: str | None = None

    @property
    def topics(self) -> list[str]:
        return [t for t, _ in self._read]

    @property
    def requests(self) -> tuple[str, ...]:
        """What each of :attr:`topics` carries, as the node's status names the request."""
        return tuple(r for _, r in self._read)

    @property
    def _read(self) -> list[tuple[str, str]]:
        return [(self.command_topic, 'command')] + [
            (t, r)
            for t, r in ((self.target_topic, 'target'), (self.any_mode_topic, 'target_any_mode'))
            if t
        ]

    def frame(self, scene: Any) -> str:
        """The frame the recorded node worked in: --frame-id, else the scene's."""
        return self.frame_id or str(scene.frame_id)


@dataclass(frozen=True)
class BagRow:
    """A bag's line in the fleet summary. ``messages`` counts every message read, those
    --state-completion skipped (no request) too: answered + refused are the requests. Stamps
    are bag receive times (ns since the epoch); margin and residual are over the answered
    commands (None when none was answered)."""

    bag: str
    source: str
    status: BagStatus
    messages: int = 0
    answered: int = 0
    refused: int = 0
    missing: int = 0
    min_margin: float | None = None
    max_residual: float | None = None
    first_stamp_ns: int | None = None
    last_stamp_ns: int | None = None
    wall_s: float = 0.0
    reason: str = ''
    resumed: bool = False
    outputs: tuple[str, ...] = field(default=())

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d['outputs'] = list(self.outputs)
        return d


SUMMARY_FIELDS = [k for k in BagRow.__dataclass_fields__ if k != 'outputs']


# ---- solving one bag (the single-bag command uses it too) ----------------------------------


def replay_input(
    engine: Any,
    mech: Any,
    source: str,
    opts: BagOptions,
    progress: Progress,
    frame_id: str,
    marks: list[float] | None = None,
    outputs: RunOutputs | None = None,
) -> tuple[Commands, Results, list[PlanRequest]]:
    """Read a bag's requests and answer them in bag order on ``engine`` (bag.replay.ReplayEngine);
    the time reading ended (perf_counter) is appended to ``marks``. The recorded plans are
    placed first and decoded one at a time when answered; with ``outputs`` each answered plan
    goes to them at once and keeps only its outcome (one plan in memory at a time)."""
    data = read_commands(
        source, opts.topics, progress, accept_missing=opts.accept_missing, requests=opts.requests
    )
    refused: dict[int, str] = {}
    if opts.state_completion:  # as joint_states_in: the inputs of each hardware message
        inputs = list(mech.commanded_input_names)
        followers = [n for n in mech.output_input_names if n not in inputs]
        data, refused = completed_commands(data, inputs, followers)
    for topic in opts.path_topics:
        if path_point(topic) not in mech.points:
            raise BagError(
                f'--path-topic {topic}: its last name {path_point(topic)!r} is not a point '
                f'of {mech.name!r} (a path topic is .../target_path/<point>)'
            )
    plans, plans_missing = read_plan_requests(
        source, opts.trajectory_topics, opts.path_topics, opts.accept_missing, mech, frame_id
    )
    data.missing.update(plans_missing)
    if marks is not None:
        marks.append(time.perf_counter())
    on_plan = outputs.start(plans) if outputs is not None else None
    topics = plan_topics(opts.trajectory_topics, opts.path_topics)
    decoded = decoded_plans(source, topics, plans)
    res = engine.solve_all(data, progress, plans, frame_id, decoded=decoded, on_plan=on_plan)
    for i, why in refused.items():  # (their rows name nothing: refused, the state unchanged)
        res.reason[i] = why
    return data, res, plans


_SCENES: dict[tuple[Any, ...], Any] = {}


def load_options_scene(opts: BagOptions) -> Any:
    """The run's scene, loaded once per process (a worker analyses many bags)."""
    key = (opts.scene, opts.dimensions, opts.closures, opts.actuated)
    scene = _SCENES.get(key)
    if scene is None:
        from ..core.loading import load_scene
        from ..resources import scene_path

        dims = dict(opts.dimensions) or None
        path = str(scene_path(opts.scene))
        scene = load_scene(path, dims, opts.closures, opts.actuated or None)
        _SCENES.clear()
        _SCENES[key] = scene
    return scene


def _row_from(task: BagTask, data: Commands, res: Results, plans: list[PlanRequest]) -> BagRow:
    ok = np.asarray(res.ok, bool)
    plans_ok = sum(1 for p in plans if p.succeeded)
    requests = data.n + len(plans)
    answered = int(np.count_nonzero(ok)) + plans_ok
    margins = res.margin[ok]
    margins = margins[~np.isnan(margins)]
    residuals = res.residual[ok]
    residuals = residuals[~np.isnan(residuals)]
    stamps = [int(t) for t in data.log_ns[[0, -1]]] if data.n else []
    stamps += [p.log_ns for p in plans]
    why = unanswered(data, res, plans)
    return BagRow(
        bag=task.name,
        source=task.source,
        status=BagStatus.REFUSED if why else BagStatus.OK,
        messages=requests + data.skipped,  # (read: --state-completion's skipped ones too)
        answered=answered,
        refused=requests - answered,
        missing=int(sum(data.missing.values())),
        min_margin=float(margins.min()) if margins.size else None,
        max_residual=float(residuals.max()) if residuals.size else None,
        first_stamp_ns=min(stamps) if stamps else None,
        last_stamp_ns=max(stamps) if stamps else None,
        reason=why or '',
    )


def unanswered(data: Commands, res: Results, plans: list[PlanRequest]) -> str | None:
    """Why a bag got no answer at all (its exit status is 1, its fleet row 'all refused'):
    every request refused, every message skipped by --state-completion, or no message on the
    topics given; None when some request was answered."""
    if int(np.count_nonzero(res.ok)) + sum(1 for p in plans if p.succeeded):
        return None
    if data.n or plans:
        return REFUSED_HINT
    if data.skipped:
        return SKIPPED_HINT.format(data.skipped)
    return EMPTY_HINT


REFUSED_HINT = (
    'every request was refused: is --scene the mechanism that was recorded, and '
    '--command-topic its commands? (the first reasons are in the outputs)'
)
#: no message on the topics given (a topic recorded empty, or the wrong one): nothing answered
EMPTY_HINT = (
    'nothing to solve: no message on the topics given; is --command-topic the topic the '
    'commands were recorded on?'
)
#: every message skipped by --state-completion: none named the mechanism's inputs
SKIPPED_HINT = (
    "none of the {} message(s) read carried the mechanism's inputs (--state-completion "
    'skipped them all): is --scene the mechanism that was recorded, and --command-topic its '
    'joint states?'
)


def _outputs(task: BagTask, opts: BagOptions, scene: Any) -> RunOutputs:
    """The bag's outputs under --out-dir (the trajectories' CSV with a CSV or Parquet table)."""
    kinds = {'csv': OutputKind.CSV, 'parquet': OutputKind.PARQUET, 'png': OutputKind.PLOT}
    kinds['svg'] = OutputKind.PLOT
    outs = [
        Output(kinds.get(fmt, OutputKind.BAG), task.output(opts.out_dir, fmt), fmt)
        for fmt in opts.formats
    ]
    for out in outs:
        out.path.parent.mkdir(parents=True, exist_ok=True)
    tables = {'csv', 'parquet'} & set(opts.formats)
    return RunOutputs(
        outs,
        scene.mechanism,
        opts.frame(scene),
        plans_csvs=[task.trajectories(opts.out_dir)] if tables else [],
        remap=dict(opts.remap),
        publish_inputs=opts.publish_inputs,
    )


def _remove(paths: list[Path]) -> None:
    for p in paths:
        with contextlib.suppress(OSError):
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()


#: the malloc thresholds a bag's analysis works well with (bytes)
_MMAP_THRESHOLD_BYTES = 32 << 20
_TRIM_THRESHOLD_BYTES = 64 << 20


def _undo_malloc_trim() -> None:
    """A Dask nanny starts its workers with MALLOC_TRIM_THRESHOLD_=65536 (to give memory back
    to the OS), which also fixes glibc's mmap threshold at 128 KiB: every array the analysis
    makes beyond that is a fresh mmap, and a bag took 2.5x as long on a worker as in a process
    pool (4 bags of 100,000 commands: 4.6-5.5 s each against 1.9-2.8 s). Where that variable is
    set, raise both thresholds again for this process (glibc only; elsewhere nothing)."""
    if 'MALLOC_TRIM_THRESHOLD_' in os.environ:
        set_malloc_thresholds(_MMAP_THRESHOLD_BYTES, _TRIM_THRESHOLD_BYTES)


#: this process's line for per-bag progress bars (0: none): set in a local pool's workers
_PROGRESS_LINE = 0


def pool_worker_init(counter: Any) -> None:
    """A local pool worker's initializer: SIGTERM's default action (a forked worker inherits
    the fleet's handler, which would make it an exception its task catches: the fleet stops
    its workers with it); and where ``counter`` is given, take the next terminal line (1, 2,
    ...) below the fleet's bar for the bars of the bags it analyses."""
    import signal

    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if counter is None:
        return
    global _PROGRESS_LINE
    with counter.get_lock():
        counter.value += 1
        _PROGRESS_LINE = counter.value


def analyse_bag(
    task: BagTask, opts: BagOptions, fingerprint: str, progress_line: int | None = None
) -> BagRow:
    """Solve one bag and write its outputs and manifest; its summary row (FAILED with the
    reason on any error, its outputs then removed: a bag's outputs are all there or none).
    ``progress_line`` (default: this process's, set by pool_worker_init; 0: none): the
    terminal line of this bag's progress bar, below the fleet's."""
    from ..core.errors import LinkageError
    from ..outputs import written_whole
    from .replay import ReplayEngine

    _undo_malloc_trim()
    t0 = time.perf_counter()
    written: list[Path] = []
    try:
        scene = load_options_scene(opts)
        mech = scene.mechanism
        engine = ReplayEngine(mech, opts.solver, opts.tol, opts.max_iter, opts.branch, opts.hold)
        line = _PROGRESS_LINE if progress_line is None else progress_line
        progress = Progress(line > 0, position=line, prefix=f'{task.name}: ')
        outputs = _outputs(task, opts, scene)
        try:
            data, res, plans = replay_input(
                engine, mech, task.source, opts, progress, opts.frame(scene), outputs=outputs
            )
            written = outputs.finish(data, res)
        except BaseException:
            outputs.abort()
            raise
        finally:
            progress.clear()
        row = _row_from(task, data, res, plans)
        rel = [p.relative_to(opts.out_dir).as_posix() for p in written]
        row = _with(row, wall_s=time.perf_counter() - t0, outputs=tuple(rel))
        manifest = {
            'version': MANIFEST_VERSION,
            'fingerprint': fingerprint,
            'row': row.as_dict(),
        }
        with written_whole(task.manifest(opts.out_dir)) as tmp:
            tmp.write_text(json.dumps(manifest, indent=1, allow_nan=False) + '\n')
        return row
    except Exception as exc:  # noqa: BLE001 - one bag fails alone, whatever went wrong
        _remove(written)
        if isinstance(exc, BagError | LinkageError):
            reason = str(exc)
        elif isinstance(exc, OSError):
            where = f' {exc.filename}' if exc.filename else ''
            reason = f'cannot write an output{where} ({exc.strerror or exc})'
        else:
            reason = f'{type(exc).__name__}: {exc_text(exc)}'
        return BagRow(
            bag=task.name,
            source=task.source,
            status=BagStatus.FAILED,
            wall_s=time.perf_counter() - t0,
            reason=reason,
        )


def _with(row: BagRow, **changes: Any) -> BagRow:
    from dataclasses import replace

    return replace(row, **changes)


# ---- resume --------------------------------------------------------------------------------


def _file_digest(path: str | None) -> str | None:
    if not path or not Path(path).is_file():
        return None
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def options_fingerprint(opts: BagOptions) -> str:
    """What every bag's outputs depend on besides the bag: the options and the scene's bytes."""
    from ..resources import scene_path

    d = asdict(opts)
    d.pop('out_dir')
    d['scene_sha256'] = _file_digest(str(scene_path(opts.scene)))
    d['closures_sha256'] = _file_digest(opts.closures)
    text = json.dumps(d, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def bag_fingerprint(task: BagTask, options_digest: str) -> str:
    """The options' fingerprint and the bag's files (name, size, modification time)."""
    p = Path(task.source)
    files = sorted(p.rglob('*')) if p.is_dir() else [p]
    parts = [options_digest]
    for f in files:
        with contextlib.suppress(OSError):
            st = f.stat()
            parts.append(
                f'{f.relative_to(p) if p.is_dir() else f.name}:{st.st_size}:{st.st_mtime_ns}'
            )
    return hashlib.sha256('\n'.join(parts).encode()).hexdigest()


def finished_row(task: BagTask, out_dir: str, fingerprint: str) -> BagRow | None:
    """The summary row of a bag this output folder already holds complete, or None."""
    try:
        manifest = json.loads(task.manifest(out_dir).read_text())
        if manifest.get('version') != MANIFEST_VERSION or manifest['fingerprint'] != fingerprint:
            return None
        d = dict(manifest['row'])
        d['outputs'] = tuple(d.get('outputs', ()))
        d['status'] = BagStatus(d['status'])  # (ValueError: not a status; run the bag again)
        row = BagRow(**d)
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if row.bag != task.name or not all(Path(out_dir, o).exists() for o in row.outputs):
        return None
    return _with(row, resumed=True)


#: the formats whose output is a bag folder (the others' are files)
FOLDER_FORMATS = ('mcap', 'sqlite3')


def stale_outputs(task: BagTask, opts: BagOptions) -> list[Path]:
    """What an earlier run left of the bag under --out-dir: its outputs in every format (not
    only this run's: a format no longer asked for would sit beside the new answers), its
    manifest, and the staging leftovers of a killed run (``.NAME.PID.partial``); BagError for
    a folder where a file output goes, or a file where an output bag (a folder) goes: not the
    tool's, never removed."""
    finals = [Path(opts.out_dir, *PurePosixPath(n).parts) for n in task.owned_names()]
    found = [p for p in finals if p.exists() or p.is_symlink()]
    for p in found:
        folder = p.is_dir() and not p.is_symlink()
        if folder != (p.suffix[1:] in FOLDER_FORMATS):  # (an output bag is a folder)
            what, goes = ('a folder', 'a file') if folder else ('a file', 'a folder (a bag)')
            raise BagError(
                f'--out-dir: {p} is {what} where {goes} output of bag {task.name} goes; it is '
                "not the tool's and is left alone: move it away"
            )
    parents = {p.parent for p in finals}
    for parent in sorted(parents):
        if parent.is_dir():
            names = {f'.{p.name}.' for p in finals if p.parent == parent}
            found += sorted(
                q
                for q in parent.iterdir()
                if q.name.endswith('.partial') and any(q.name.startswith(n) for n in names)
            )
    return found


def remove_outputs(paths: list[Path]) -> None:
    """Remove an unfinished bag's leftovers before it is redone (--resume)."""
    _remove(paths)
