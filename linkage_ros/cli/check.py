"""``linkage check``: links, joints, DOF, Grashof class, input ranges, solve plan."""

from __future__ import annotations

import math
from typing import Any

from ..core.mechanism import actuator_kind
from ..core.model import AngleActuator
from .common import OK, dumps, fmt_value, load_scene_file, print_notes
from .described import InputValues
from .process import say

# ---- check -------------------------------------------------------------------------------------


def check_report(
    mech,
    path: str,
    solver_method: str | None,
    notes: tuple[str, ...] | list[str] = (),
    warnings: tuple[str, ...] | list[str] = (),
) -> dict:
    """The check of a loaded mechanism (JSON-ready). ``notes`` and ``warnings``: the scene's
    own (what loading did; what loads but is likely wrong)."""
    from ..core.motion import actuator_ranges, input_limits_lifted
    from ..core.motion.other_circuits import other_circuits
    from ..core.motion.quantities import quantities_report
    from ..core.reference_warnings import reference_pose_warnings
    from ..core.solver import SolveMode, Solver

    desc = mech.describe()
    grashof = None
    from ..core.analysis import four_link_chain_info

    c = four_link_chain_info(mech)  # any one-loop four-link scene driven by a crank
    if c is not None:
        grashof = {
            'chain': c.chain,
            'class': c.klass,
            'input_fully_rotates': c.input_fully_rotates,
            'output_fully_rotates': c.output_fully_rotates,
            'rule': c.rule,
        }
    full = actuator_ranges(mech)  # (each input's range and full_turn)
    ranges = {name: (i['min'], i['max']) for name, i in full.items()}
    values = InputValues(mech)  # a robot description's: its joint names and values
    solver = Solver(mech, method=solver_method, branch='reference')
    drawn = solver.reference_values()
    inputs = {}
    for name, act in mech.actuators.items():
        lo, hi = values.interval(name, *ranges.get(name, (None, None)))
        declared = values.interval(name, act.min, act.max)
        inputs[values.name(name)] = {
            'kind': actuator_kind(act),
            'unit': 'rad' if isinstance(act, AngleActuator) else 'm',
            'min': lo,  # the range the input can take: the declared limits, or tighter
            'max': hi,
            'declared_min': declared[0],  # the scene's own limits (None: none given)
            'declared_max': declared[1],
            'full_turn': bool(full[name]['full_turn']) if name in full else False,
            # its value in the drawing (the reference pose): a lecture's "present value"
            'drawn': values.value(name, float(drawn[name])) if name in drawn else None,
            # where it assembles apart from the drawing's circuit (another circuit)
            'other_circuits': [list(values.interval(name, *c)) for c in other_circuits(mech, name)],
        }
    n_act = len(mech.actuators)
    free = input_limits_lifted(mech, next(iter(mech.actuators))) if n_act == 1 else None
    motion = quantities_report(mech)
    return {
        'scene': path,
        'name': mech.name,
        'form': mech.form.value,
        'links': desc['links'],
        # the reference pose (m): a point placed by distances on the wrong side shows here
        'points': {p: [float(xy[0]), float(xy[1])] for p, xy in mech.points.items()},
        'joints': desc['joints'],
        'dimensions': dict(mech.stated),  # stated by name, used exactly (m)
        'n_links': desc['n_links'],
        'n_joints': desc['n_joints'],
        'dof': mech.dof,
        'n_actuators': n_act,
        'dof_matches_actuators': mech.dof == n_act,
        'grashof': grashof,
        'inputs': inputs,
        'plan': {
            'solver': solver.method.value,
            'mode': solver.mode,
            'knowns': list(solver.knowns),
            'closed_form_steps': [] if solver.mode is SolveMode.NEWTON else solver.plan.describe(),
            'closed_form_links': list(solver.closed_links),
            'newton_links': list(solver.system.free),
            'branch_count': solver.branch_count,
        },
        'warnings': [
            *warnings,
            *reference_pose_warnings(solver),
            *_structure_warnings(mech, solver),
        ],
        'motion': described_motion(motion, values),
        # the motion through the toggles a crank's limits stop short of (None: no such limits,
        # or limits that take in the whole circuit)
        'motion_without_limits': described_motion(through_toggles(motion, free), values),
        'notes': list(notes),  # what loading did (a robot description assembled, ...)
        # a robot description's joints as published, and the scene known each request
        # name stands for (None: a scene file, published as it is)
        'joint_coordinates': None if values.jm is None else values.jm.describe(),
    }


def _structure_warnings(mech, solver) -> list[str]:
    """A structure (0 DOF, no actuator) that does not assemble with its stated dimensions: its
    solve is refused; say so, with the miss the solve reports."""
    if mech.dof != 0 or mech.actuators:
        return []
    r = solver.solve({}, commit=False)
    return [] if r.success else [f'the structure does not assemble: {r.reason}']


def described_motion(m: dict | None, values: InputValues) -> dict | None:
    """A quantities_report with its actuator in a robot description's name and values."""
    if not m or values.jm is None:
        return m
    act = m['actuator']
    if 'unavailable' in m:
        return {**m, 'actuator': values.name(act)}
    for section in ('outputs', 'transmission_angle'):
        for e in m[section].values():
            for key in ('input_at_min', 'input_at_max'):
                e[key] = values.value(act, e[key])
    return {**m, 'actuator': values.name(act)}


def format_check(r: dict) -> str:
    out = [f'scene      {r["name"]} ({r["form"]})  {r["scene"]}']
    w = max(len(k) for k in list(r['links']) + list(r['joints']) + list(r['inputs']))
    out.append(f'links ({r["n_links"]})')
    out += [f'  {k:<{w}}  {" ".join(v)}' for k, v in r['links'].items()]
    pw = max([len(k) for k in r['points']] + [w])
    out.append(f'{"points (reference pose)":<{pw + 2}}  {"x (m)":>14} {"y (m)":>14}')
    out += [f'  {k:<{pw}}  {x:14.9g} {y:14.9g}' for k, (x, y) in r['points'].items()]
    out.append(f'joints ({r["n_joints"]})')
    for k, j in r['joints'].items():
        if j['type'] == 'revolute':
            out.append(f'  {k:<{w}}  revolute   at {j["point"]}: {j["parent"]} -> {j["child"]}')
        else:
            out.append(
                f'  {k:<{w}}  prismatic  {j["point"]} of {j["slider"]} slides in {j["guide"]}'
            )
    if r['dimensions']:
        out.append('dimensions (stated, used exactly)')
        out += [f'  {k} = {v:.12g} m' for k, v in r['dimensions'].items()]
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
        klass = g['class']
        if klass == 'crank-rocker' and g['output_fully_rotates'] and not g['input_fully_rotates']:
            # seed 000's crank-rocker has its input turning: here the output is the crank
            klass = 'crank-rocker, its output the crank (a rocker-crank)'
        elif klass == 'triple-rocker':  # (seed 000 names it by what it is not)
            klass = 'non-Grashof triple-rocker (a non-Grashof double-rocker: no link turns fully)'
        out.append(
            f'grashof    {g["chain"]} {klass}: {g["rule"]}'
            + (f' ({", ".join(turns)})' if turns else '')
        )
    out.append('inputs')
    for k, v in r['inputs'].items():
        rng = (
            'unlimited'
            if v['min'] is None and v['max'] is None
            else f'min {fmt_value(v["min"], ".9g")}  max {fmt_value(v["max"], ".9g")} {v["unit"]}'
        )
        if v['unit'] == 'rad' and v['min'] is not None and v['max'] is not None:
            rng += f'  ({math.degrees(v["min"]):.4f} .. {math.degrees(v["max"]):.4f} deg)'
        declared = (v.get('declared_min'), v.get('declared_max'))
        if declared != (v['min'], v['max']):  # a computed range replaced the scene's limits
            said = (
                'none'
                if declared == (None, None)
                else f'min {fmt_value(declared[0], ".9g")}  max {fmt_value(declared[1], ".9g")}'
            )
            # (no range where the declared ones limit nothing: an angle's a turn or more
            # apart, as limits in degrees read as radians are; the warning says so)
            rng += (
                f'  [reachable range, computed; declared limits: {said}]'
                if rng != 'unlimited'
                else f'  [declared limits {said}: a turn or more apart, they limit nothing]'
            )
        if v.get('drawn') is not None:
            rng += f'  drawn {fmt_value(v["drawn"], ".9g")}'
        out.append(f'  {k:<{w}}  {v["kind"]:<5}  {rng}')
        for lo, hi in v.get('other_circuits') or ():
            out.append(
                f'  {"":<{w}}  also assembles over {fmt_value(lo, ".9g")} .. '
                f'{fmt_value(hi, ".9g")} {v["unit"]}: another circuit (reached only by taking '
                'the linkage apart)'
            )
    p = r['plan']
    out.append(
        f'plan       solver {p["solver"]} -> mode {p["mode"]}; '
        f'knowns {", ".join(p["knowns"]) or "none (a structure: 0 DOF)"}'
        + (f'; {p["branch_count"]} branching dyad(s)' if p['closed_form_steps'] else '')
    )
    if p['closed_form_steps']:
        out.append('  closed-form steps')
        out += [f'    {i + 1}. {s}' for i, s in enumerate(p['closed_form_steps'])]
    out.append(f'  placed by closed-form dyads: {", ".join(p["closed_form_links"]) or "(none)"}')
    out.append(f'  placed by Newton:            {", ".join(p["newton_links"]) or "(none)"}')
    jc = r.get('joint_coordinates')
    if jc:
        out.append(f"published  the description's joints: {', '.join(jc['joints'])}")
        out.append(
            '  requests   '
            + ', '.join(
                k if k == v else f'{k} (scene {v})' for k, v in sorted(jc['inputs'].items())
            )
        )
    out += format_motion(r.get('motion'), r.get('motion_without_limits'))
    out += [f'warning    {w}' for w in r.get('warnings', [])]
    return '\n'.join(out)


def cmd_check(args) -> int:
    scene = load_scene_file(args.scene, args.dimension, args.closures, args.actuated)
    if not args.json:
        print_notes(scene.notes)
    report = check_report(
        scene.mechanism, str(scene.path), args.solver, scene.notes, scene.warnings
    )
    say(dumps(report) if args.json else format_check(report))
    return OK


def through_toggles(motion: dict | None, free: Any) -> dict | None:
    """The quantities_report of ``free`` (the mechanism with its input's limits lifted) where
    an output's extremes differ from ``motion``'s (the limits stop short of the toggles), else
    None."""
    from ..core.motion.quantities import quantities_report

    if motion is None or free is None or 'unavailable' in motion:
        return None
    whole = quantities_report(free)
    if whole is None or 'unavailable' in whole:
        return None
    moved = any(_moved(o, whole['outputs'].get(name)) for name, o in motion['outputs'].items())
    return whole if moved else None


def _moved(o: dict, whole: dict | None) -> bool:
    """Whether an output's extremes without the input's limits (``whole``) differ from its
    extremes within them (``o``) beyond rounding."""

    def same(a: float, b: float) -> bool:
        return abs(a - b) <= 1e-12 * max(1.0, abs(a), abs(b))

    return whole is not None and not (same(whole['min'], o['min']) and same(whole['max'], o['max']))


def _on_branch(extreme: dict, end: str) -> str:
    """' on branch S' where the circuit passes more than one sign combination of the forward
    dyads (an input has a configuration on each: a landing gear's brace past its dead centre;
    seed 002: a non-Grashof four-bar's two are 'two distinct configurations', one assembly
    mode), else ''. (JSON: ``mode_at_min`` / ``mode_at_max``.)"""
    mode = extreme.get(f'mode_at_{end}')
    return f' on branch {mode}' if mode else ''


def format_motion(m: dict | None, free: dict | None = None) -> list[str]:
    """The text lines of a quantities_report (``linkage check`` and ``linkage range --motion``);
    ``free``: the report without the input's limits, whose extremes are added where they differ
    (the lectures' oscillation of a link is its whole circuit, through the toggles)."""
    if not m:
        return []
    out = []
    act = m['actuator']
    if 'unavailable' in m:
        return [f'motion     {act}: not computed ({m["unavailable"]})']
    out.append(f'motion     {act} over {"a full turn" if m["full_turn"] else "its range"}')
    for name, o in m['outputs'].items():
        kind, _, bare = name.partition(':')
        unit = 'rad' if kind == 'link' else 'm'
        line = (
            f'  {bare} ({"angle" if kind == "link" else "slide"})  min {fmt_value(o["min"])} '
            f'at {act} {fmt_value(o["input_at_min"])}{_on_branch(o, "min")}  max '
            f'{fmt_value(o["max"])} at {act} {fmt_value(o["input_at_max"])}{_on_branch(o, "max")}'
            f'  {"swing" if unit == "rad" else "stroke"} {fmt_value(o["stroke"])} {unit}'
        )
        if o.get('time_ratio') is not None:
            line += f'  time ratio {fmt_value(o["time_ratio"], ".6g")}'
        out.append(line)
        whole = (free or {}).get('outputs', {}).get(name)
        if _moved(o, whole):
            assert whole is not None
            out.append(
                f"    without the input's limits (through its toggles): min "
                f'{fmt_value(whole["min"])}  max {fmt_value(whole["max"])}  '
                f'{"swing" if unit == "rad" else "stroke"} {fmt_value(whole["stroke"])} {unit}'
            )
    for name in m.get('turns_fully', ()):
        out.append(f'  {name.partition(":")[2]} (angle)  turns fully (no swing, no time ratio)')
    for key, t in m['transmission_angle'].items():
        out.append(
            f'  transmission angle {key}  min {fmt_value(t["min"], ".6g")} rad '
            f'({math.degrees(t["min"]):.3f} deg) at {act} {fmt_value(t["input_at_min"], ".9g")}'
            f'{_on_branch(t, "min")}  max {fmt_value(t["max"], ".6g")} rad '
            f'({math.degrees(t["max"]):.3f} deg) at {act} {fmt_value(t["input_at_max"], ".9g")}'
            f'{_on_branch(t, "max")}'
        )
    return out
