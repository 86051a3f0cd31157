"""What the linkage subcommands share: exit codes, parsing of values and ranges, loading a
scene, building a solve, output formatting."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..core.errors import CommandError
from ..core.model import SlideActuator
from ..core.model.names import point_coordinate
from ..core.quantities import AngleSpec, PointSpec
from ..core.steps import BranchRule, read_branch
from ..core.units import Quantity, Reading, UnitError, degrees_warning, expect, parse_text
from .arguments import OnceAction

USAGE_ERROR, REFUSED, OK = 2, 1, 0


class UsageError(Exception):
    """A command line that cannot be run; printed as one line, exit status 2."""


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr (exit 2), and an option that takes one
    value is refused given twice (OnceAction: argparse keeps the last silently)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.register('action', None, OnceAction)
        self.register('action', 'store', OnceAction)

    def error(self, message):
        self.exit(USAGE_ERROR, f'{self.prog}: error: {message} (see {self.prog} --help)\n')


class KnownAction(argparse.Action):
    """--set / --target / --target-point all append (option, text) to one list, keeping the
    command-line order (it is the sweep grid order)."""

    def __call__(self, parser, namespace, values, option_string=None):
        items = list(getattr(namespace, 'knowns', None) or [])
        items.append((option_string, values))
        namespace.knowns = items


# ---- parsing helpers ---------------------------------------------------------------------------


def _number(text: str, what: str) -> Reading:
    """'0.5' -> Reading(0.5); '30deg' -> Reading(radians, 'deg'); '16mm' -> Reading(0.016,
    'mm'): the unit grammar of core.units (the quantity is checked once the name's is known)."""
    try:
        return parse_text(text)
    except UnitError as exc:
        raise UsageError(f'{what}: {text.strip()!r} {exc}') from None


def _point(text: str, what: str) -> tuple[float, float]:
    parts = text.split(',')
    if len(parts) != 2:
        raise UsageError(f'{what}: {text!r} is not a point X,Y')
    x, y = (_number(p, what) for p in parts)
    for reading, part in ((x, parts[0]), (y, parts[1])):
        try:
            expect(reading, Quantity.LENGTH)
        except UnitError as exc:
            raise UsageError(f'{what}: {part.strip()!r} {exc}') from None
    return x.value, y.value


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


def command_grid(axes):
    """The sweep grid lazily, first axis slowest: itertools.product would copy every axis into
    a tuple before yielding anything."""
    if not axes:
        yield ()
        return
    for v in axes[0]:
        for rest in command_grid(axes[1:]):
            yield (v,) + rest


def parse_known(option: str, text: str, allow_range: bool):
    """One --set/--target/--target-point argument -> (name, values, readings).

    Scalars: NAME=VALUE or NAME=START:STOP:COUNT; points: NAME=X,Y or NAME=X0,Y0:X1,Y1:COUNT.
    ``values`` is a list (one element unless a range), in rad or m; ``readings`` the scalar
    values as written (VALUE, or START and STOP; none for a point, always metres), whose
    units :func:`check_units` holds against the name's quantity."""
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
            return name, [_point(parts[0], what)], ()
        reading = _number(parts[0], what)
        return name, [reading.value], (reading,)
    if len(parts) != 3:
        raise UsageError(f'{option} {text!r}: expected {shape}')
    if not allow_range:
        raise UsageError(f'{option} {text!r}: ranges START:STOP:COUNT are for `linkage sweep`')
    n = _count(parts[2], what)
    if point:
        return name, _linspace(_point(parts[0], what), _point(parts[1], what), n), ()
    a, b = _number(parts[0], what), _number(parts[1], what)
    return name, _linspace(a.value, b.value, n), (a, b)


def check_units(what: str, readings: Sequence[Reading], spec) -> None:
    """Refuse a unit of the wrong quantity for ``spec`` (UsageError naming ``what``), and
    warn on stderr about a bare angle beyond a full turn (likely degrees)."""
    quantity = Quantity.ANGLE if isinstance(spec, AngleSpec) else Quantity.LENGTH
    for reading in readings:
        written = reading.quantity
        if written is not None and written is not quantity:
            raise UsageError(
                f'{what}: {reading.unit!r} is a unit of {written.value}, but '
                f'{spec.name!r} is {"an angle" if quantity is Quantity.ANGLE else "a length"} '
                f'({spec.unit}, or with a unit: {", ".join(quantity.units)})'
            )
    if quantity is Quantity.ANGLE:
        warning = next(
            (w for w in (degrees_warning(what, r) for r in readings) if w is not None), None
        )
        if warning is not None:
            print(f'warning: {warning}', file=sys.stderr)


# ---- scene, solver and output helpers ----------------------------------------------------------


def dimension_argument(text: str) -> tuple[str, float]:
    """argparse type of --dimension NAME=VALUE."""
    from ..core.model.dimensions import parse_assignment

    try:
        return parse_assignment(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def dimension_overrides(pairs: Sequence[tuple[str, float]]) -> dict[str, float] | None:
    """The --dimension options as a mapping; a name given twice is a usage error."""
    from ..core.model.dimensions import overrides

    try:
        return overrides(pairs)
    except ValueError as exc:
        raise UsageError(f'--dimension: {exc}') from None


def add_scene_argument(
    p: argparse.ArgumentParser, flag: bool = False, descriptions: bool = True
) -> None:
    """SCENE (or --scene), the repeatable --dimension NAME=VALUE that overrides its stated
    dimensions by name, and (unless ``descriptions`` is False: a command that refuses robot
    descriptions) the robot description's --closures FILE and --actuated NAME."""
    what = (
        'scene file, packaged scene name, or robot description (.urdf, .sdf, .xml)'
        if descriptions
        else 'scene file or packaged scene name'
    )
    if flag:
        p.add_argument('--scene', required=True, help=what)
    else:
        p.add_argument('scene', metavar='SCENE', help=what)
    p.add_argument(
        '--dimension',
        action='append',
        default=[],
        type=dimension_argument,
        metavar='NAME=VALUE',
        help='a dimension used exactly instead of the drawing (m, or with a unit: 16mm): '
        'LINK.P-Q, the distance between two points of a link, or SLIDER.offset (repeatable; '
        'see docs/SCENES.md)',
    )
    if descriptions:
        add_description_arguments(p)


#: a robot description's file names (core.description.importer.DESCRIPTION_SUFFIXES, which
#: the CLI does not import for a scene file: the readers add 0.05 s to every command's start)
DESCRIPTION_SUFFIXES = ('.urdf', '.sdf', '.xml', '.xacro')


def add_description_arguments(p: argparse.ArgumentParser) -> None:
    """--closures FILE and the repeatable --actuated NAME of a robot description."""
    p.add_argument(
        '--closures',
        metavar='FILE',
        default=None,
        help='robot description only: a closure side file (a linkage_ros closure file or '
        "Gepetto's YAML) stating where its loops close (see docs/ROBOT_DESCRIPTIONS.md)",
    )
    p.add_argument(
        '--actuated',
        action='append',
        default=[],
        metavar='NAME',
        help='robot description only: an actuated joint, where neither the description nor '
        'the closure file marks them (repeatable)',
    )


def description_options_error(
    path: str, closures: str | None, actuated: Sequence[str] = ()
) -> str | None:
    """Why --closures / --actuated cannot go with ``path`` (a scene file), or None."""
    from ..core.description import is_description

    if (closures or actuated) and not is_description(path):
        option = '--closures' if closures else '--actuated'
        return (
            f'{option} applies to a robot description (.urdf, .sdf, .xml); the scene file '
            f'{path} states its closures and actuators itself'
        )
    return None


def load_scene_file(
    scene: str,
    dimensions: Sequence[tuple[str, float]] = (),
    closures: str | None = None,
    actuated: Sequence[str] = (),
):
    """The Scene (mechanism, path, notes) of a scene file, packaged scene or robot
    description (with its closure side file and actuated joints)."""
    from ..resources import config_dir, scene_path

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
    if not (closures or actuated or str(path).lower().endswith(DESCRIPTION_SUFFIXES)):
        from ..core.model import Scene  # a scene file: the description readers stay unloaded

        return Scene.from_yaml(path, dimension_overrides(dimensions))
    from ..core.loading import load_scene

    why = description_options_error(str(path), closures, actuated)
    if why:
        raise UsageError(why)
    return load_scene(str(path), dimension_overrides(dimensions), closures, list(actuated) or None)


def print_notes(notes: Sequence[str]) -> None:
    """What loading did that a user should hear (a description assembled, its mimics
    superseded): one line each on stderr."""
    for note in notes:
        print(f'note: {note}', file=sys.stderr)


def print_warnings(warnings: Sequence[str]) -> None:
    """What loads but is likely wrong (a bare angle beyond a full turn): one line each on
    stderr, with JSON output too (stdout stays the document)."""
    for warning in warnings:
        print(f'warning: {warning}', file=sys.stderr)


def load_mechanism(
    scene: str,
    dimensions: Sequence[tuple[str, float]] = (),
    closures: str | None = None,
    actuated: Sequence[str] = (),
):
    """The scene's mechanism and its path; ``dimensions`` override its stated dimensions; a
    robot description takes ``closures`` and ``actuated``. The scene's warnings and notes go
    to stderr, with --json too (its answer is stdout's)."""
    loaded = load_scene_file(scene, dimensions, closures, actuated)
    print_warnings(loaded.warnings)
    print_notes(loaded.notes)
    return loaded.mechanism, str(loaded.path)


def build_solve(mech, args, allow_range: bool):
    """The knowns of a solve/sweep command line -> (knowns, axes, Solver).

    ``axes`` is [(name, [values...])] in command-line order; a fixed value is a 1-element axis.
    ``knowns`` are the solver's. For a mechanism read from a robot description the names and
    values are the description's: ``knowns`` are the scene's they stand for, and a command
    built from ``axes`` goes through :func:`described.scene_command` before the solver."""
    from ..core.plan import spec_for
    from ..core.solver import Solver
    from .described import commanded, grouped_knowns, scene_names

    acts = commanded(mech)  # mech.actuators, or the description's commanded actuated joints
    items = getattr(args, 'knowns', None) or []
    if not items and mech.dof:  # a structure (0 DOF) is solved with no knowns: where it goes
        raise UsageError(
            'nothing to solve: give --set NAME=VALUE for each actuator '
            f'({", ".join(acts)}), or --target / --target-point'
        )
    axes: list[Any] = []
    options: dict[str, Any] = {}
    knowns: list[str] = []
    given: dict[str, str] = {}  # the solver's known -> the name on the command line
    for option, text in items:
        name, values, readings = parse_known(option, text, allow_range)
        if name in options:
            raise UsageError(f'{name!r} is given twice ({options[name]} and {option})')
        options[name] = option
        if option == '--target-point':
            if name not in mech.points:
                raise UsageError(f'--target-point {name}: {name!r} is not a point of {mech.name!r}')
            name = f'point:{name}'  # a point may share its name with a joint
            options[name] = option
        try:
            names = scene_names(mech, name)  # a description's joint -> the scene's known(s)
        except CommandError as exc:
            raise UsageError(f'{option} {name}: {exc}') from None
        if option == '--set' and name not in acts:
            raise UsageError(
                f'--set {name}: {name!r} is not an actuator of {mech.name!r} '
                f'(actuators: {", ".join(acts)}); use --target for joints, '
                'links or points'
            )
        spec = spec_for(mech, names[0])  # PlanError for an unknown name
        if option != '--target-point' and isinstance(spec, PointSpec):
            raise UsageError(f'{option} {name}: {name!r} is a point; use --target-point {name}=X,Y')
        check_units(f'{option} {name}', readings, spec)
        for known in names:
            if known in given:
                raise UsageError(
                    f'{given[known]!r} and {name!r} name the same known {known!r} of {mech.name!r}'
                )
            given[known] = name
            knowns.append(known)
        axes.append((name, values))
    inverse = not all(options[n] == '--set' for n, _ in axes)
    if not inverse:
        missing = [a for a in acts if a not in options]
        if missing:  # held where the drawing has them, as the node holds what a command omits
            for name, value in _drawn_values(mech, missing).items():
                for known in scene_names(mech, name):
                    knowns.append(known)
                axes.append((name, [value]))
                unit = spec_for(mech, scene_names(mech, name)[0]).unit
                print(
                    f'note: {name} held at its drawn value {value:.9g} {unit} (no --set for '
                    'it: as the node holds an actuator a command leaves out)',
                    file=sys.stderr,
                )
    solver = Solver(
        mech,
        knowns=grouped_knowns(mech, knowns),  # P.x and P.y: the point, as the node takes them
        method=args.solver,
        tol=args.tol,
        max_iter=args.max_iter,
        # signs name a mode of the forward plan: a target's solver follows its own plan, and
        # the target rule (target_engine) keeps its answers in that mode
        branch='continuous' if inverse else args.branch,
    )  # PlanError: exit 2
    return knowns, axes, solver


def _drawn_values(mech, names: Sequence[str]) -> dict[str, float]:
    """The drawing's (reference pose's) value of each commanded input ``names``, in the
    command line's terms (a robot description's joint values)."""
    from ..core.solver import Solver
    from .described import InputValues

    values = InputValues(mech)
    drawn = Solver(mech, branch='reference').reference_values()
    out = {}
    for name in names:
        v = values.value(values.actuator(name), float(drawn[values.actuator(name)]))
        assert v is not None
        out[name] = v
    return out


def _rule(branch: str) -> BranchRule | None:
    """The branch setting's rule (read_branch), None for text that is no setting."""
    read = read_branch(branch)
    return None if read is None else read.rule


def _signs(branch: str) -> bool:
    """The branch setting names a mode itself (signs, or a Jacobian sign)."""
    return _rule(branch) in (BranchRule.EXPLICIT, BranchRule.JACOBIAN)


def target_engine(mech, args, single: bool = False):
    """The node's engine for the command line's solver options: targets are answered as a
    node with that ``branch`` parameter answers them. ``single`` (`linkage solve`, one request
    from the drawing): ``reference`` is the engine's start, continuous from the drawing (its
    mode, or its circuit through a toggle: --any-mode may change it)."""
    from ..engine import Engine, EngineSettings

    if getattr(args, 'any_mode', False) and _signs(args.branch):
        raise UsageError(f'--any-mode and --branch {args.branch} go against each other: the '
                         'signs keep every answer in their mode')  # fmt: skip
    settings = EngineSettings(
        solver=args.solver,
        tolerance=args.tol,
        max_iterations=args.max_iter,
        branch='continuous'
        if single and _rule(args.branch) is BranchRule.REFERENCE
        else args.branch,
    )
    return Engine(mech, settings)


def forward_engine(mech, args):
    """The node's engine for a forward solve or sweep with the command line's solver options:
    its commands are answered as the node answers ~/command (Engine.forward_solve: on the
    drawing's circuit, continuous from the drawing)."""
    from ..engine import Engine, EngineSettings

    settings = EngineSettings(
        solver=args.solver, tolerance=args.tol, max_iterations=args.max_iter, branch=args.branch
    )
    return Engine(mech, settings)


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


def fmt_value(v, spec='.9g') -> str:
    return '-' if v is None else format(v, spec)


def _angle(v) -> str:
    return '-' if v is None else f'{v: .9f} rad  {math.degrees(v): 11.5f} deg'


def _unit_of(mech, name: str) -> str:
    """'m' for prismatic joints, slide actuators and point coordinates (``D.x``), 'rad'
    otherwise (a robot description's joint: by its type)."""
    from .described import unit_of

    if point_coordinate(mech, name) is not None:
        return 'm'

    unit = unit_of(mech, name)
    if unit is not None:
        return unit
    if name in mech.prismatics:
        return 'm'
    act = mech.actuators.get(name)
    return 'm' if act is not None and isinstance(act, SlideActuator) else 'rad'


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
        out.append(f'residual   {fmt_value(d["residual"], ".3g")} (of the length scale)')
        out.append(
            f'branch     {d["branch"] or "(none)"}'
            + (
                ''
                if d['branch_defined']
                else '  (undefined: at a toggle, or where two circles coincide and a point '
                'may turn about them)'
            )
        )
        out.append(f'margin     {fmt_value(d["margin"], ".6g")}')
        if d.get('cond') is not None:
            out.append(f'cond(J)    {fmt_value(d["cond"], ".6g")}')
    out.append(f'solver     {d["solver"]}   iterations {d["iterations"]}')
    return '\n'.join(out)


def file_name(text: str) -> str:
    """An argparse type for an output path: not empty (`--csv ''` was silently no file,
    `--out ''` 'exists already', `--out-dir ''` the current folder: an adversary)."""
    if not text:
        raise argparse.ArgumentTypeError('needs a file or folder name (got an empty one)')
    return text


def write_text_output(prog: str, text: str, path: str | None, inputs: Sequence[str] = ()) -> int:
    """A command's text document to ``path`` (written whole or not at all) or to stdout; the
    exit status (a file that cannot be written, or one of the command's ``inputs``: one line
    on stderr, USAGE_ERROR)."""
    from ..outputs import input_refusal, name_refusal, written_whole

    why = (name_refusal(path) or input_refusal(path, inputs)) if path else None
    if why:
        print(f'{prog}: error: cannot write {path}: {why}', file=sys.stderr)
        return USAGE_ERROR
    try:
        if path:
            with written_whole(path) as tmp:
                tmp.write_text(text, encoding='utf-8')
        else:
            sys.stdout.write(text)
    except OSError as exc:
        where = path or 'standard output'
        print(f'{prog}: error: cannot write {where}: {exc.strerror or exc}', file=sys.stderr)
        return USAGE_ERROR
    return OK
