"""``linkage solve``: one forward or inverse solve."""

from __future__ import annotations

from .common import OK, REFUSED, build_solve, dumps, format_result, load_mechanism

# ---- solve -------------------------------------------------------------------------------------


def cmd_solve(args) -> int:
    mech, _ = load_mechanism(args.scene)
    _, axes, solver = build_solve(mech, args, allow_range=False)
    command = {n: vals[0] for n, vals in axes}
    results = solver.solve_all(command) if args.all_branches else [solver.solve(command)]
    dicts = [r.to_dict(mech) for r in results]
    if args.json:
        print(dumps(dicts if args.all_branches else dicts[0]))
    else:
        for i, d in enumerate(dicts):
            if args.all_branches:
                print(
                    f'--- assembly mode {i + 1} of {len(dicts)}'
                    + (f' (branch {d["branch"]})' if d['branch'] else '')
                )
            print(format_result(d, mech))
    return OK if any(r.success for r in results) else REFUSED
