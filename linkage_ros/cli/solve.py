"""``linkage solve``: one forward or inverse solve.

A single solve is the node's first request: it goes through the same Engine, starting from the
scene's reference pose. An inverse solve is answered in the reference pose's assembly mode within
the actuator limits (the inverse plan's other branches are searched when its own lands in
another mode or on a limit), or refused naming the mode that would reach it; ``--any-mode``
allows that mode, as the node's ``~/target_any_mode`` does. ``--all-branches`` lists every mode.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from ..core.solver import Result, SolveMode
from .common import (
    OK,
    REFUSED,
    UsageError,
    build_solve,
    dumps,
    format_result,
    forward_engine,
    load_mechanism,
    target_engine,
)
from .described import beyond_limits, request_echo, scene_command
from .process import say

if TYPE_CHECKING:
    from collections.abc import Callable, Sequence

    from ..core.solver.modes import ModeList

# ---- solve -------------------------------------------------------------------------------------


def roller_legend(modes: ModeList) -> str:
    """Which branch sign is which roller's side, and the side each is drawn on."""
    return '\n'.join(
        f'roller {c.joint}: branch sign {c.index + 1} of {len(modes.drawn)} is the side of its '
        f'face (+ left of its direction, - right); drawn {c.drawn}'
        for c in modes.rollers
    )


def _drawn_mode_rule(
    mech, args, modes: ModeList
) -> tuple[Callable[[Result], bool], Callable[[Sequence[Result]], str]]:
    """Whether a solution of ``modes`` is in the drawing's assembly mode: on the drawing's
    circuit where that circuit passes its toggles (DrawingCircuit.holds: a non-Grashof four-bar's
    two signs are one mode; a Grashof double-rocker's mirror loop, in the drawn signs, is
    another), else in the drawn branch signs; and which circuit holds all of several
    solutions ('the drawing's', 'the other': a four-bar's other loop, its one branching dyad
    on two circuits; '' where not one or not known)."""
    engine = forward_engine(mech, args)

    def in_drawn_mode(r: Result) -> bool:
        on = engine.circuit.holds(r)
        return r.branch == modes.drawn if on is None else on

    def one_circuit(rs: Sequence[Result]) -> str:
        on = {engine.circuit.holds(r) for r in rs}
        if len(rs) < 2 or len(on) != 1:
            return ''
        if on == {True}:
            return "the drawing's"
        one_dyad = all(len(r.branch) == 1 for r in rs)
        return 'the other' if on == {False} and one_dyad else ''

    return in_drawn_mode, one_circuit


def _note_twin(mech, solver, command, r: Result, engine) -> None:
    """Given one coordinate of a point, a Newton inverse has two solutions in one assembly
    mode, either side of that coordinate's extreme (seed 003's loader: D.x and the bin angle,
    "D.y will be automatically decided"); a closed-form inverse may have two too, its inverse
    dyad's two sides (a toggle clamp's arm angle, reached by the handle either side of its
    dead centre): where the answer has such a twin, a note on stderr names it (the node answers
    with the one nearest its last state), in the inputs a command takes (a robot description's
    joint values) and only where the robot can take it (no joint beyond its <limit>, as
    ``engine`` refuses them). (Closed form: its modes are listed at once; a Newton inverse's
    search costs 0.1-0.6 s, paid where a twin is the rule.)"""
    from ..core.quantities import CoordinateSpec

    coordinate = any(isinstance(s, CoordinateSpec) for s in solver.specs)
    if not r.success or not (coordinate or solver.mode is SolveMode.CLOSED_FORM):
        return
    far = 1e-6 * mech.length_scale
    told: list[str] = []  # every other solution in the answer's mode (a five-bar's target point
    # has three in one mode: the note named one, an outside scene author)
    for other in solver.modes(command).results:
        if other.branch != r.branch or not other.success:
            continue
        names, values = mech.output_input_names, mech.output_inputs(other.inputs)
        given = dict(zip(names, (float(v) for v in values)))
        jc = mech.joint_coordinates
        if engine.beyond_passive_limits(other) is not None or (
            jc is not None and jc.refusal(given) is not None
        ):
            continue
        gap = max(
            (abs(other.points[p][k] - r.points[p][k]) for p in r.points for k in (0, 1)),
            default=0.0,
        )
        if gap > far:
            told.append(', '.join(f'{a} = {v:.9g}' for a, v in given.items()))
    if told:
        mode = r.branch or '(one mode)'
        what = 'another solution' if len(told) == 1 else f'{len(told)} other solutions'
        print(
            f'note: {what} in assembly mode {mode}: {"; ".join(told)}; '
            '--all-branches lists every solution',
            file=sys.stderr,
        )


def cmd_solve(args) -> int:
    mech, _ = load_mechanism(args.scene, args.dimension, args.closures, args.actuated)
    knowns, axes, solver = build_solve(mech, args, allow_range=False)
    given = {n: vals[0] for n, vals in axes}
    command = scene_command(mech, given)  # a robot description's names and values -> the scene's
    if args.any_mode and (args.all_branches or not solver.inverse):
        raise UsageError('--any-mode applies to an inverse solve (--target, --target-point)')
    modes = None
    beyond = beyond_limits(mech, given)
    if beyond is not None:  # (as the node refuses it: before any solve)
        results = [Result(False, beyond)]
    elif args.all_branches:
        modes = solver.modes(command)
        results = modes.results
    elif solver.inverse:
        # the assembly mode of the reference pose (or the one --branch names), kept as a real
        # mechanism keeps it
        engine = target_engine(mech, args, single=True)
        results = [engine.solve_target(solver, command, allow_mode_change=args.any_mode)]
        _note_twin(mech, solver, command, results[0], engine)
    else:  # as the node answers ~/command from its drawing
        engine = forward_engine(mech, args)
        r = engine.forward_solve(command)
        if len(mech.actuators) > 1:
            # several actuators: told where the way from the drawing stops, every actuator
            # moved together, as a target's (one actuator's gets its reachable range from
            # the engine). Here, not in the node: marching costs ms a refusal, and commands
            # are its control path
            engine.way_edge(engine.forward, command, r, keep_mode=False)
        results = [r]
    dicts = [request_echo(mech, r.to_dict(mech), given) for r in results]
    in_drawn_mode, one_circuit = (
        _drawn_mode_rule(mech, args, modes) if modes is not None and modes.drawn else (None, None)
    )
    for d, r in zip(dicts, results):
        if r.mode_change:
            d['mode_change'] = r.mode_change
        if modes is not None:  # whether the list is provably every assembly mode
            d['modes_complete'] = modes.complete
            if modes.drawn and in_drawn_mode is not None:
                # the mode the drawing is in, and each roller's side of its face
                d['drawn_mode'] = in_drawn_mode(r)
            if modes.rollers:
                sides = modes.roller_sides(r)
                d['rollers'] = {
                    c.joint: {'side': sides.get(c.joint), 'drawn_side': c.drawn}
                    for c in modes.rollers
                }
    if args.json:
        say(dumps(dicts if args.all_branches else dicts[0]))
    else:
        # a search may find more than one solution in one mode (a Newton inverse: the two
        # roots either side of one coordinate's extreme): then it lists solutions
        labels = {d['branch'] for d in dicts}
        each = 'assembly mode' if len(labels) == len(dicts) or labels == {''} else 'solution'
        # every solution on one circuit through its toggles (the drawing's, or a Grashof
        # double-rocker's other loop): one assembly mode in two configurations (seed 002: a
        # non-Grashof four-bar's two solutions 'are not two distinct assembly modes but two
        # distinct configurations')
        circuit = '' if one_circuit is None else one_circuit(results)
        if circuit:
            each = 'configuration'
            say(
                f'one assembly mode: {len(dicts)} configurations on {circuit} circuit, which '
                'passes its toggles through both branch signs'
            )
        if modes is not None and not modes.complete:
            say(
                (
                    f'assembly modes: {len(dicts)} found ({modes.method})'
                    if each == 'assembly mode'
                    else f'solutions: {len(dicts)} found in {len(labels)} assembly mode(s) '
                    f'{", ".join(sorted(labels))} ({modes.method})'
                )
                + (
                    f'; {modes.singular} start(s) ended on a continuum of solutions (singular: '
                    'e.g. a folded cell), not listed'
                    if modes.singular
                    else ''
                )
            )
        if modes is not None and modes.rollers:
            say(roller_legend(modes))
        for i, d in enumerate(dicts):
            if args.all_branches:
                say(
                    f'--- {each} {i + 1} of {len(dicts)}'
                    + (f' (branch {d["branch"]})' if d['branch'] else '')
                    + (' (as drawn)' if d.get('drawn_mode') else '')
                )
                for joint, side in d.get('rollers', {}).items():
                    say(
                        f'roller {joint}: {side["side"]} of its face '
                        + ('(as drawn)' if side['side'] == side['drawn_side'] else '(not drawn)')
                    )
            say(format_result(d, mech))
            if d.get('mode_change'):
                say(f'assembly mode changed: {d["mode_change"]} (--any-mode)')
    return OK if any(r.success for r in results) else REFUSED
