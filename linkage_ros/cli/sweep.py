"""``linkage sweep``: a grid of commands, JSON lines out (and, with ``--csv``, the trajectory of
every actuator and joint as CSV: the answers go into the core's results table, the one
``linkage bag`` fills, and the CSV is written from it with the bag CSV's column names)."""

from __future__ import annotations

import csv
import math
import sys
from typing import Any

import numpy as np

from ..core.solver import Result
from ..core.solver.table import ResultTable
from ..outputs import folder_refusal, input_refusal, text_cell, written_whole
from .common import (
    OK,
    REFUSED,
    UsageError,
    build_solve,
    command_grid,
    dumps,
    fmt_value,
    forward_engine,
    load_mechanism,
    target_engine,
)
from .described import beyond_limits, request_echo, scene_command
from .process import stdout_gone

# ---- sweep -------------------------------------------------------------------------------------


class _Table:
    """The table (or JSON lines) on stdout. A reader that stops early (``| head``) ends the
    table, not the sweep, when a --csv file is asked for: the file is still written whole."""

    def __init__(self) -> None:
        self.open = True

    def print(self, text: str) -> None:
        if not self.open:
            return
        try:
            print(text)
        except BrokenPipeError:
            self.close()

    def flush(self) -> None:
        if self.open:
            try:
                sys.stdout.flush()
            except BrokenPipeError:
                self.close()

    def close(self) -> None:
        self.open = False
        stdout_gone()


#: the most rows a --csv sweep keeps (about 0.1 kB each in memory, the CSV's table and its
#: text; --json streams any number)
MAX_CSV_ROWS = 2_000_000


def _count(values: Any) -> int:
    """How many values an axis holds (a count beyond sys.maxsize too, where len() raises
    OverflowError: `crank=0:1:99999999999999999999999 --csv` was a traceback)."""
    return int(getattr(values, 'n', None) or len(values))


def _check_csv_path(path: str, scene_file: str) -> None:
    """A --csv path whose folder cannot take it, or that is the scene file, is refused before
    any solve."""
    why = folder_refusal(path) or input_refusal(path, [scene_file])
    if why:
        raise UsageError(f'--csv {path}: {why}')


def _cell(v) -> str:
    if isinstance(v, (list, tuple)):
        return f'{v[0]:.6g},{v[1]:.6g}'
    return f'{v:.6g}'


def cmd_sweep(args) -> int:
    mech, scene_file = load_mechanism(args.scene, args.dimension, args.closures, args.actuated)
    _, axes, solver = build_solve(mech, args, allow_range=True)
    if args.csv:
        _check_csv_path(args.csv, scene_file)
        rows = math.prod(_count(vals) for _, vals in axes)
        if rows > MAX_CSV_ROWS:
            # (a 10^9-point --csv grew without bound before: an adversary)
            raise UsageError(
                f'--csv keeps every answer until its file is written: {rows:,} grid points are '
                f'more than {MAX_CSV_ROWS:,}; sweep fewer, or take --json (one line per point, '
                'streamed)'
            )
    out = _Table()
    names = [n for n, _ in axes]
    outs = [p for p in mech.outputs]
    solved_inputs = [a for a in mech.output_input_names if a not in names]
    if not args.json:
        head = (
            ['#']
            + names
            + ['status']
            + solved_inputs
            + [f'{p}.x,{p}.y' for p in outs]
            + ['residual', 'branch', 'margin']
        )
        out.print('\t'.join(head))
    # targets and commands as a node answers them (in the mode --branch names; commands on
    # the drawing's circuit)
    engine = target_engine(mech, args) if solver.inverse else forward_engine(mech, args)
    # lazy: a 10^9-point grid starts printing at once (only --csv, which keeps every answer
    # for its table, lists it first)
    grid = command_grid([vals for _, vals in axes])
    table = None
    if args.csv:
        table = ResultTable.for_mechanism(mech, math.prod(_count(vals) for _, vals in axes))
    n_ok = n_err = 0
    for i, combo in enumerate(grid):
        command = dict(zip(names, combo))
        known = scene_command(mech, command)  # a robot description's names and values
        beyond = beyond_limits(mech, command)
        if beyond is not None:
            res = Result(False, beyond)
        elif solver.inverse:
            res = engine.solve_target(solver, known)
        else:
            res = engine.forward_solve(known)
        if table is not None:
            # a refused row keeps what it was commanded, as linkage bag's table does (a refusal
            # before any solve, a description's joint beyond its <limit>, echoes no inputs)
            for nm, v in known.items():
                if nm in table.inputs:
                    table.inputs[nm][i] = v
            table.put_result(i, res)
        n_ok += res.success
        n_err += not res.success
        d = request_echo(mech, res.to_dict(mech), command)
        if args.json:
            d['index'] = i
            d['command'] = {k: list(v) if isinstance(v, tuple) else v for k, v in command.items()}
            out.print(dumps(d))
        else:
            out.print('\t'.join(_row(i, command, names, d, res.success, solved_inputs, outs)))
        if not out.open and table is None:  # the reader has stopped and no file is asked for
            break
    out.flush()
    if table is not None:
        _write_csv(args.csv, mech, table)
    total = n_ok + n_err
    # (on stderr, and the status of the rows solved, also where the table's reader stopped
    # early: `--strict | head` exited 0 after an error without a word, an adversary's find)
    cut = ' before the reader of the table stopped' if not out.open and table is None else ''
    print(f'linkage sweep: {total} command(s){cut}, {n_ok} ok, {n_err} error(s)', file=sys.stderr)
    return REFUSED if args.strict and n_err else OK


def _row(i, command, names, d, ok, solved_inputs, outs) -> list[str]:
    """One line of the table: the command, its status and what was solved (or why not)."""
    row = [str(i)] + [_cell(command[n]) for n in names] + [d['status']]
    if ok:
        row += [_cell(d['inputs'][a]) if a in d['inputs'] else '-' for a in solved_inputs]
        row += [_cell(d['points'][p]) if p in d['points'] else '-' for p in outs]
        row += [fmt_value(d['residual'], '.2g'), d['branch'] or '-', fmt_value(d['margin'], '.4g')]
    else:
        row += [d['reason'] or 'refused']
    return row


def _csv_rows(mech, table: ResultTable) -> list[list]:
    """index, status, reason, every input and joint of each row; a refused row keeps the
    inputs it was commanded (as linkage bag's CSV does; angles wrapped as the answers give
    them), its other cells empty."""
    n = table.n

    def listed(values) -> list[list[float]]:
        return [np.broadcast_to(np.asarray(v, float), (n,)).tolist() for v in values]

    inputs = listed(mech.output_inputs(table.inputs))
    joints = listed(mech.output_joints(table.joints, table.inputs))
    rows = []
    for i in range(n):
        if not table.ok[i]:
            given = [repr(c[i]) if math.isfinite(c[i]) else '' for c in inputs]
            reason = text_cell(table.reason[i] or 'refused')
            rows.append([i, 'error', reason, *given] + [''] * len(joints))
            continue
        rows.append([i, 'ok', ''] + [repr(c[i]) for c in (*inputs, *joints)])
    return rows


def _write_csv(path: str, mech, table: ResultTable) -> None:
    head = ['index', 'status', 'reason']
    head += [f'input.{a}' for a in mech.output_input_names]
    head += [f'joint.{j}' for j in mech.output_joint_names]
    try:
        with written_whole(path) as tmp, open(tmp, 'w', newline='') as fh:
            w = csv.writer(fh)
            w.writerow(head)
            w.writerows(_csv_rows(mech, table))
    except OSError as exc:
        raise UsageError(f'--csv: cannot write {path}: {exc.strerror or exc}') from None
