"""``linkage sweep``: a grid of commands, JSON lines out."""

from __future__ import annotations

import sys

from .common import OK, REFUSED, _f, _grid, build_solve, dumps, load_mechanism

# ---- sweep -------------------------------------------------------------------------------------


def _cell(v) -> str:
    if isinstance(v, (list, tuple)):
        return f'{v[0]:.6g},{v[1]:.6g}'
    return f'{v:.6g}'


def cmd_sweep(args) -> int:
    mech, _ = load_mechanism(args.scene)
    _, axes, solver = build_solve(mech, args, allow_range=True)
    names = [n for n, _ in axes]
    outs = [p for p in mech.outputs]
    solved_inputs = [a for a in mech.actuators if a not in names]
    if not args.json:
        head = (
            ['#']
            + names
            + ['status']
            + solved_inputs
            + [f'{p}.x,{p}.y' for p in outs]
            + ['residual', 'branch', 'margin']
        )
        print('\t'.join(head))
    n_ok = n_err = 0
    for i, combo in enumerate(_grid([vals for _, vals in axes])):
        command = dict(zip(names, combo))
        res = solver.solve(command)
        n_ok += res.success
        n_err += not res.success
        d = res.to_dict(mech)
        if args.json:
            d['index'] = i
            d['command'] = {k: list(v) if isinstance(v, tuple) else v for k, v in command.items()}
            print(dumps(d))
            continue
        row = [str(i)] + [_cell(command[n]) for n in names] + [d['status']]
        if res.success:
            row += [_cell(d['inputs'][a]) if a in d['inputs'] else '-' for a in solved_inputs]
            row += [_cell(d['points'][p]) if p in d['points'] else '-' for p in outs]
            row += [_f(d['residual'], '.2g'), d['branch'] or '-', _f(d['margin'], '.4g')]
        else:
            row += [d['reason'] or 'refused']
        print('\t'.join(row))
    sys.stdout.flush()
    total = n_ok + n_err
    print(f'linkage sweep: {total} command(s), {n_ok} ok, {n_err} error(s)', file=sys.stderr)
    return REFUSED if args.strict and n_err else OK
