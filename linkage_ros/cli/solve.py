"""``linkage solve``: one forward or inverse solve.

A single solve is the node's first request: it goes through the same Engine, starting from the
scene's reference pose. An inverse solve is answered in the reference pose's assembly mode within
the actuator limits (the inverse plan's other branches are searched when its own lands in
another mode or on a limit), or refused naming the mode that would reach it; ``--any-mode``
allows that mode, as the node's ``~/target_any_mode`` does. ``--all-branches`` lists every mode.
"""

from __future__ import annotations

from .common import (
    OK,
    REFUSED,
    UsageError,
    build_solve,
    dumps,
    format_result,
    load_mechanism,
    target_engine,
)
from .described import request_echo, scene_command

# ---- solve -------------------------------------------------------------------------------------


def cmd_solve(args) -> int:
    mech, _ = load_mechanism(
        args.scene, args.dimension, args.closures, args.actuated, notes=not args.json
    )
    knowns, axes, solver = build_solve(mech, args, allow_range=False)
    given = {n: vals[0] for n, vals in axes}
    command = scene_command(mech, given)  # a robot description's names and values -> the scene's
    if args.any_mode and (args.all_branches or not solver.inverse):
        raise UsageError('--any-mode applies to an inverse solve (--target, --target-point)')
    modes = None
    if args.all_branches:
        modes = solver.modes(command)
        results = modes.results
    elif solver.inverse and args.branch == 'reference':
        # the assembly mode of the reference pose, kept as a real mechanism keeps it
        engine = target_engine(mech, args)
        results = [engine.solve_target(solver, command, allow_mode_change=args.any_mode)]
    else:
        results = [solver.solve(command)]
    dicts = [request_echo(mech, r.to_dict(mech), given) for r in results]
    for d, r in zip(dicts, results):
        if r.mode_change:
            d['mode_change'] = r.mode_change
        if modes is not None:  # whether the list is provably every assembly mode
            d['modes_complete'] = modes.complete
    if args.json:
        print(dumps(dicts if args.all_branches else dicts[0]))
    else:
        if modes is not None and not modes.complete:
            print(
                f'assembly modes: {len(dicts)} found ({modes.method})'
                + (
                    f'; {modes.singular} start(s) ended on a continuum of solutions (singular: '
                    'e.g. a folded cell), not listed'
                    if modes.singular
                    else ''
                )
            )
        for i, d in enumerate(dicts):
            if args.all_branches:
                print(
                    f'--- assembly mode {i + 1} of {len(dicts)}'
                    + (f' (branch {d["branch"]})' if d['branch'] else '')
                )
            print(format_result(d, mech))
            if d.get('mode_change'):
                print(f'assembly mode changed: {d["mode_change"]} (--any-mode)')
    return OK if any(r.success for r in results) else REFUSED
