"""The ``linkage`` command: one-shot solves, sweeps and scene checks from the shell.

    linkage solve SCENE --set NAME=VALUE ... [--target NAME=VALUE] [--target-point NAME=X,Y]
                        [--branch B] [--solver S] [--tol T] [--max-iter N] [--all-branches] [--json]
    linkage sweep SCENE --set NAME=START:STOP:COUNT ... [--set NAME=VALUE] [--target ...]
                        [--branch B] [--solver S] [--tol T] [--max-iter N] [--strict] [--json]
    linkage check SCENE [--solver S] [--json]

SCENE is a scene file or the name of a packaged scene (``four_bar``). Angles are radians (a value
may end in ``deg``: ``--set crank=30deg``), lengths metres.

Exit status: 0 ok; 1 a solve was refused (the answer has status "error" and a reason; with
``--all-branches`` only when no assembly mode closes; ``sweep --strict`` when any line is an
error); 2 a usage error (bad syntax, unknown name, missing scene, SceneError, PlanError), reported
as one line on stderr; 130 interrupted by Ctrl-C (one line, no traceback).

The CLI only parses, calls the core and prints: no kinematics lives here. More subcommands plug in
through :data:`EXTERNAL_COMMANDS` (modules with ``add_arguments(parser)`` and
``run(args) -> int``).
"""

from __future__ import annotations

import argparse
import importlib
import json
import math
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .core.errors import LinkageError

#: subcommand -> module defining ``add_arguments(parser)`` and ``run(args) -> int``; a module that
#: does not import is left out (the reason shows in ``linkage --help``).
EXTERNAL_COMMANDS = {
    'range': 'linkage_ros.range_cli',
    'bag': 'linkage_ros.bag',
    'bench': 'linkage_ros.bench',
}

USAGE_ERROR, REFUSED, OK = 2, 1, 0
INTERRUPTED = 130  # Ctrl-C, as a shell reports a SIGINT


class UsageError(Exception):
    """A command line that cannot be run; printed as one line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr (exit 2)."""

    def error(self, message):
        self.exit(USAGE_ERROR, f'{self.prog}: error: {message} (see {self.prog} --help)\n')


class _Known(argparse.Action):
    """--set / --target / --target-point all append (option, text) to one list, keeping the
    command-line order (it is the sweep grid order)."""

    def __call__(self, parser, namespace, values, option_string=None):
        items = list(getattr(namespace, 'knowns', None) or [])
        items.append((option_string, values))
        namespace.knowns = items


# ---- parsing helpers ---------------------------------------------------------------------------


def _number(text: str, what: str) -> tuple[float, bool]:
    """'0.5' -> (0.5, False); '30deg' -> (radians, True). Finite numbers only."""
    t = text.strip()
    deg = t.lower().endswith('deg')
    if deg:
        t = t[:-3].strip()
    try:
        v = float(t)
    except ValueError:
        raise UsageError(f'{what}: {text!r} is not a number') from None
    if not math.isfinite(v):
        raise UsageError(f'{what}: {text!r} must be a finite number')
    return (math.radians(v) if deg else v), deg


def _point(text: str, what: str) -> tuple[float, float]:
    parts = text.split(',')
    if len(parts) != 2:
        raise UsageError(f'{what}: {text!r} is not a point X,Y')
    (x, dx), (y, dy) = (_number(p, what) for p in parts)
    if dx or dy:
        raise UsageError(f'{what}: a point is in metres, not degrees')
    return x, y


def _count(text: str, what: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise UsageError(f'{what}: COUNT {text!r} is not an integer') from None
    if n < 1:
        raise UsageError(f'{what}: COUNT must be >= 1 (got {n})')
    return n


class _Linspace(Sequence):
    """n evenly spaced values from a to b inclusive (floats or (x, y) tuples), computed when read:
    a sweep of a billion lines must not build its list of values first."""

    def __init__(self, a, b, n: int):
        self.a, self.b, self.n = a, b, n

    def __len__(self) -> int:
        return self.n

    def __getitem__(self, i):
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(self.n))]
        if i < 0:
            i += self.n
        if not 0 <= i < self.n:
            raise IndexError(i)
        a, b, n = self.a, self.b, self.n
        if n == 1:
            return a
        if isinstance(a, tuple):
            return tuple(a[k] + (b[k] - a[k]) * i / (n - 1) for k in range(2))
        return a + (b - a) * i / (n - 1)

    def __iter__(self):
        return (self[i] for i in range(self.n))


def _linspace(a, b, n):
    """n evenly spaced values from a to b inclusive (floats or (x, y) tuples), lazily."""
    return _Linspace(a, b, n)


def _grid(axes):
    """The sweep grid lazily, first axis slowest: itertools.product would copy every axis into
    a tuple before yielding anything."""
    if not axes:
        yield ()
        return
    for v in axes[0]:
        for rest in _grid(axes[1:]):
            yield (v,) + rest


def parse_known(option: str, text: str, allow_range: bool):
    """One --set/--target/--target-point argument -> (name, values, used_deg).

    Scalars: NAME=VALUE or NAME=START:STOP:COUNT; points: NAME=X,Y or NAME=X0,Y0:X1,Y1:COUNT.
    ``values`` is a list (one element unless a range)."""
    point = option == '--target-point'
    shape = ('NAME=X,Y' if point else 'NAME=VALUE') + (
        ' or NAME=X0,Y0:X1,Y1:COUNT'
        if point and allow_range
        else ' or NAME=START:STOP:COUNT'
        if allow_range
        else ''
    )
    name, sep, rhs = text.partition('=')
    name = name.strip()
    if not sep or not name or not rhs.strip():
        raise UsageError(f'{option} {text!r}: expected {shape}')
    what = f'{option} {name}'
    parts = rhs.split(':')
    if len(parts) == 1:
        if point:
            return name, [_point(parts[0], what)], False
        v, deg = _number(parts[0], what)
        return name, [v], deg
    if len(parts) != 3:
        raise UsageError(f'{option} {text!r}: expected {shape}')
    if not allow_range:
        raise UsageError(f'{option} {text!r}: ranges START:STOP:COUNT are for `linkage sweep`')
    n = _count(parts[2], what)
    if point:
        return name, _linspace(_point(parts[0], what), _point(parts[1], what), n), False
    (a, da), (b, db) = _number(parts[0], what), _number(parts[1], what)
    return name, _linspace(a, b, n), da or db


# ---- scene, solver and output helpers ----------------------------------------------------------


def load_mechanism(scene: str):
    from .core.model import Scene
    from .resources import config_dir, scene_path

    try:
        path = scene_path(scene)
    except OSError as exc:  # the ROS package index is unusable (unset environment)
        raise UsageError(
            f'scene {scene!r} not found: not a file, and packaged scenes cannot be located: {exc}'
        ) from None
    if not Path(path).exists():
        try:
            avail = sorted(p.stem for p in config_dir().glob('*.yaml'))
        except OSError:
            avail = []
        raise UsageError(
            f'scene {scene!r} not found: not a file and not a packaged scene'
            + (f' (packaged: {", ".join(avail)})' if avail else '')
        )
    return Scene.from_yaml(path).mechanism, str(path)


def build_solve(mech, args, allow_range: bool):
    """The knowns of a solve/sweep command line -> (knowns, axes, Solver).

    ``axes`` is [(name, [values...])] in command-line order; a fixed value is a 1-element axis."""
    from .core.plan import spec_for
    from .core.solver import Solver

    items = getattr(args, 'knowns', None) or []
    if not items:
        raise UsageError(
            'nothing to solve: give --set NAME=VALUE for each actuator '
            f'({", ".join(mech.actuators)}), or --target / --target-point'
        )
    axes: list[Any] = []
    options: dict[str, Any] = {}
    for option, text in items:
        name, values, deg = parse_known(option, text, allow_range)
        if name in options:
            raise UsageError(f'{name!r} is given twice ({options[name]} and {option})')
        options[name] = option
        if option == '--set' and name not in mech.actuators:
            raise UsageError(
                f'--set {name}: {name!r} is not an actuator of {mech.name!r} '
                f'(actuators: {", ".join(mech.actuators)}); use --target for joints, '
                'links or points'
            )
        if option == '--target-point':
            if name not in mech.points:
                raise UsageError(f'--target-point {name}: {name!r} is not a point of {mech.name!r}')
            name = f'point:{name}'  # a point may share its name with a joint
            options[name] = option
        spec = spec_for(mech, name)  # PlanError for an unknown name
        if option != '--target-point' and spec.kind == 'point':
            raise UsageError(f'{option} {name}: {name!r} is a point; use --target-point {name}=X,Y')
        if deg and spec.kind != 'angle':
            raise UsageError(f'{option} {name}: a "deg" suffix on a length ({spec.unit})')
        axes.append((name, values))
    knowns = [n for n, _ in axes]
    if all(options[n] == '--set' for n in knowns):
        missing = [a for a in mech.actuators if a not in options]
        if missing:
            raise UsageError(f'missing --set for actuator(s) {", ".join(missing)} of {mech.name!r}')
    solver = Solver(
        mech,
        knowns=knowns,
        method=args.solver,
        tol=args.tol,
        max_iter=args.max_iter,
        branch=args.branch,
    )  # PlanError: exit 2
    return knowns, axes, solver


def clean(obj: Any) -> Any:
    """JSON-safe copy: tuples -> lists, numpy scalars -> Python, non-finite floats -> None."""
    if isinstance(obj, dict):
        return {str(k): clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean(v) for v in obj]
    if hasattr(obj, 'item') and not isinstance(obj, (str, bytes)):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def dumps(obj: Any) -> str:
    return json.dumps(clean(obj), allow_nan=False)


def _f(v, spec='.9g') -> str:
    return '-' if v is None else format(v, spec)


def _angle(v) -> str:
    return '-' if v is None else f'{v: .9f} rad  {math.degrees(v): 11.5f} deg'


def _unit_of(mech, name: str) -> str:
    """'m' for prismatic joints and slide actuators, 'rad' otherwise."""
    if name in mech.prismatics:
        return 'm'
    act = mech.actuators.get(name)
    return 'm' if act is not None and act.kind == 'slide' else 'rad'


def _value(mech, name, v) -> str:
    if isinstance(v, (list, tuple)):
        return f'({v[0]: .9f}, {v[1]: .9f}) m'
    return _angle(v) if _unit_of(mech, name) == 'rad' else f'{v: .9f} m'


def format_result(d: dict, mech) -> str:
    """Readable table of one Result.to_dict."""
    out = [f'status     {d["status"]}']
    if d['reason']:
        out.append(f'reason     {d["reason"]}')
    w = max(
        [len(k) for sec in ('inputs', 'joints', 'links', 'points') for k in d.get(sec, {})]
        + [len(k) for k in d.get('targets', {})]
        + [6]
    )
    if d.get('targets'):
        out.append('targets')
        out += [f'  {k:<{w}}  {_value(mech, k, v)}' for k, v in d['targets'].items()]
    for sec in ('inputs', 'joints'):
        if d[sec]:
            out.append(sec)
            out += [f'  {k:<{w}}  {_value(mech, k, v)}' for k, v in d[sec].items()]
    if d['links']:
        out.append('links')
        for k, v in d['links'].items():
            out.append(f'  {k:<{w}}  {_angle(v["angle"])}   [{" ".join(v["points"])}]')
    if d['points']:
        out.append(f'points     {"x (m)":>14} {"y (m)":>14}')
        out += [f'  {k:<{w}}  {x:14.9f} {y:14.9f}' for k, (x, y) in d['points'].items()]
    if d['status'] == 'ok':
        out.append(f'residual   {_f(d["residual"], ".3g")} (of the length scale)')
        out.append(
            f'branch     {d["branch"] or "(none)"}'
            + ('' if d['branch_defined'] else '  (undefined: at a toggle)')
        )
        out.append(f'margin     {_f(d["margin"], ".6g")}')
        if d.get('cond') is not None:
            out.append(f'cond(J)    {_f(d["cond"], ".6g")}')
    out.append(f'solver     {d["solver"]}   iterations {d["iterations"]}')
    return '\n'.join(out)


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


# ---- check -------------------------------------------------------------------------------------


def input_ranges(mech) -> dict[str, tuple[float | None, float | None]]:
    """{actuator: (min or None, max or None)} from core.motion; until that module exists, the
    scene's limits and, for four_bar shortcut scenes, the crank's closed-form range."""
    try:
        from .core.motion import input_ranges as ranges
    except ModuleNotFoundError as exc:
        if exc.name not in ('linkage_ros.core.motion',):
            raise
    else:
        return ranges(mech)
    out = {a.name: (a.min, a.max) for a in mech.actuators.values()}
    sc = mech.shortcut
    if mech.form == 'four_bar' and out.get('crank') == (None, None):
        from .core.analysis import fourbar_input_range

        r = fourbar_input_range(sc['ground'], sc['crank'], sc['coupler'], sc['rocker'])
        if r is not None:
            out['crank'] = (r[0] + sc['ground_angle'], r[1] + sc['ground_angle'])
    return out


def check_report(mech, path: str, solver_method: str | None) -> dict:
    from .core.solver import Solver

    desc = mech.describe()
    grashof = None
    from .core.analysis import four_link_chain_info

    c = four_link_chain_info(mech)  # any one-loop four-link scene driven by a crank
    if c is not None:
        grashof = {
            'chain': c.chain,
            'class': c.klass,
            'input_fully_rotates': c.input_fully_rotates,
            'output_fully_rotates': c.output_fully_rotates,
            'rule': c.rule,
        }
    ranges = input_ranges(mech)
    inputs = {}
    for name, act in mech.actuators.items():
        lo, hi = ranges.get(name, (None, None))
        inputs[name] = {
            'kind': act.kind,
            'unit': 'rad' if act.kind == 'angle' else 'm',
            'min': lo,
            'max': hi,
        }
    solver = Solver(mech, method=solver_method, branch='reference')
    n_act = len(mech.actuators)
    return {
        'scene': path,
        'name': mech.name,
        'form': mech.form,
        'links': desc['links'],
        'joints': desc['joints'],
        'n_links': desc['n_links'],
        'n_joints': desc['n_joints'],
        'dof': mech.dof,
        'n_actuators': n_act,
        'dof_matches_actuators': mech.dof == n_act,
        'grashof': grashof,
        'inputs': inputs,
        'plan': {
            'solver': solver.method,
            'mode': solver.mode,
            'knowns': list(solver.knowns),
            'closed_form_steps': [] if solver.mode == 'newton' else solver.plan.describe(),
            'closed_form_links': list(solver.closed_links),
            'newton_links': list(solver.system.free),
            'branch_count': solver.branch_count,
        },
    }


def format_check(r: dict) -> str:
    out = [f'scene      {r["name"]} ({r["form"]})  {r["scene"]}']
    w = max(len(k) for k in list(r['links']) + list(r['joints']) + list(r['inputs']))
    out.append(f'links ({r["n_links"]})')
    out += [f'  {k:<{w}}  {" ".join(v)}' for k, v in r['links'].items()]
    out.append(f'joints ({r["n_joints"]})')
    for k, j in r['joints'].items():
        if j['type'] == 'revolute':
            out.append(f'  {k:<{w}}  revolute   at {j["point"]}: {j["parent"]} -> {j["child"]}')
        else:
            out.append(
                f'  {k:<{w}}  prismatic  {j["point"]} of {j["slider"]} slides in {j["guide"]}'
            )
    out.append(
        f'mobility   Kutzbach 3(n-1)-2j = 3({r["n_links"]}-1)-2*{r["n_joints"]} = '
        f'{r["dof"]} DOF; {r["n_actuators"]} actuator(s): '
        + ('match' if r['dof_matches_actuators'] else 'MISMATCH')
    )
    g = r['grashof']
    if g is not None:
        turns = [
            f'{end} fully rotates: {"yes" if g[f"{end}_fully_rotates"] else "no"}'
            for end in ('input', 'output')
            if g[f'{end}_fully_rotates'] is not None
        ]
        out.append(
            f'grashof    {g["chain"]} {g["class"]}: {g["rule"]}'
            + (f' ({", ".join(turns)})' if turns else '')
        )
    out.append('inputs')
    for k, v in r['inputs'].items():
        rng = (
            'unlimited'
            if v['min'] is None and v['max'] is None
            else f'min {_f(v["min"], ".9g")}  max {_f(v["max"], ".9g")} {v["unit"]}'
        )
        if v['unit'] == 'rad' and v['min'] is not None and v['max'] is not None:
            rng += f'  ({math.degrees(v["min"]):.4f} .. {math.degrees(v["max"]):.4f} deg)'
        out.append(f'  {k:<{w}}  {v["kind"]:<5}  {rng}')
    p = r['plan']
    out.append(
        f'plan       solver {p["solver"]} -> mode {p["mode"]}; '
        f'knowns {", ".join(p["knowns"])}'
        + (f'; {p["branch_count"]} branching dyad(s)' if p['closed_form_steps'] else '')
    )
    if p['closed_form_steps']:
        out.append('  closed-form steps')
        out += [f'    {i + 1}. {s}' for i, s in enumerate(p['closed_form_steps'])]
    out.append(f'  placed by closed-form dyads: {", ".join(p["closed_form_links"]) or "(none)"}')
    out.append(f'  placed by Newton:            {", ".join(p["newton_links"]) or "(none)"}')
    return '\n'.join(out)


def cmd_check(args) -> int:
    mech, path = load_mechanism(args.scene)
    report = check_report(mech, path, args.solver)
    print(dumps(report) if args.json else format_check(report))
    return OK


# ---- parser ------------------------------------------------------------------------------------

KNOWN_HELP = """\
knowns (in command-line order; with `sweep` that order is the grid order):
  --set NAME=VALUE          an actuator value (rad or m; "30deg" is accepted for angles)
  --target NAME=VALUE       a joint value, a link's angle (from +x) or an actuator: inverse solve
  --target-point NAME=X,Y   a point's position (m): inverse solve
  --set and --target may be combined: the knowns are all the names given, and they must fix
  every degree of freedom (e.g. one actuator and one joint angle of the 2-DOF plagiograph).
"""

SOLVE_EPILOG = (
    KNOWN_HELP
    + """
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
A scene that does not load (e.g. DOF != actuators) is an error: exit 2.
"""

MAIN_EPILOG = """\
SCENE is a scene file or the name of a packaged scene (e.g. four_bar).
exit status: 0 ok, 1 solve refused, 2 usage error, 130 interrupted (Ctrl-C).
`linkage COMMAND --help` for details.
"""


def _add_solve_options(p, default_branch: str, ranges: bool):
    p.add_argument('scene', metavar='SCENE', help='scene file or packaged scene name')
    g = p.add_argument_group('knowns')
    r = '[:STOP:COUNT]' if ranges else ''
    g.add_argument(
        '--set',
        action=_Known,
        metavar=f'NAME=VALUE{r}',
        dest='knowns',
        help='actuator value' + (' or range' if ranges else '') + ' (repeatable)',
    )
    g.add_argument(
        '--target',
        action=_Known,
        metavar=f'NAME=VALUE{r}',
        dest='knowns',
        help='joint / link angle / actuator to reach: inverse solve (repeatable)',
    )
    g.add_argument(
        '--target-point',
        action=_Known,
        dest='knowns',
        metavar='NAME=X,Y' + ('[:X1,Y1:COUNT]' if ranges else ''),
        help='point position to reach: inverse solve (repeatable)',
    )
    s = p.add_argument_group('solver')
    s.add_argument(
        '--branch',
        default=default_branch,
        help="assembly mode: 'continuous', 'reference' or one sign per branching "
        f"dyad such as '+-' (default {default_branch})",
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
        default=1e-12,
        help='Newton tolerance, relative to the length scale (default 1e-12)',
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
    parser = _Parser(
        prog='linkage',
        description='Solve, sweep and check planar linkage scenes.',
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = parser.add_subparsers(dest='command', metavar='COMMAND', parser_class=_Parser)
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
        help='every assembly mode of the command (ignores --branch)',
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
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser(
        'check',
        help='links, joints, DOF, Grashof class, input ranges, solve plan',
        description='Check a scene and describe how it will be solved.',
        epilog=CHECK_EPILOG,
        formatter_class=fmt,
    )
    p.add_argument('scene', metavar='SCENE', help='scene file or packaged scene name')
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


def standalone_main(prog: str, add_arguments, run, argv: Sequence[str] | None = None) -> int:
    """Run one subcommand module on its own (``python -m linkage_ros.bag ...``): its parser,
    then run(args); argparse's usage errors become exit status 2 instead of SystemExit."""
    parser = argparse.ArgumentParser(
        prog=prog, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_arguments(parser)
    try:
        args = parser.parse_args(list(sys.argv[1:] if argv is None else argv))
    except SystemExit as exc:
        return exc.code if isinstance(exc.code, int) else 2
    return run(args)


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser, broken = build_parser()
    if argv and argv[0] in broken:
        print(
            f'linkage: error: command {argv[0]!r} is unavailable: {broken[argv[0]]}',
            file=sys.stderr,
        )
        return USAGE_ERROR
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # --help (0) or a usage error (2)
        return exc.code if isinstance(exc.code, int) else USAGE_ERROR
    prog = f'linkage {args.command}'
    try:
        return int(args.func(args))
    except (UsageError, LinkageError) as exc:
        print(f'{prog}: error: {exc}', file=sys.stderr)
        return USAGE_ERROR
    except BrokenPipeError:  # `linkage sweep ... | head`
        sys.stdout = open(os.devnull, 'w')  # noqa: SIM115 no second error when Python flushes at exit
        return OK
    except KeyboardInterrupt:  # Ctrl-C: the shell's convention, no traceback
        print(f'\n{prog}: interrupted', file=sys.stderr)
        return INTERRUPTED


if __name__ == '__main__':
    sys.exit(main())
