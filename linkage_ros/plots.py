"""PNG figures of motion analysis: reachable regions and output-versus-input curves.

matplotlib is imported lazily (Agg backend, no display, no pyplot global state), so importing this
module costs nothing and the core never depends on it. Every function writes one PNG and returns
the plotted data as plain lists.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .core.errors import PlanError
from .core.model import AngleActuator, SlideActuator
from .core.model.names import NameKind, point_coordinate, resolve_name
from .outputs import written_whole

_BRANCH_COLOURS = (
    'tab:blue',
    'tab:orange',
    'tab:green',
    'tab:red',
    'tab:purple',
    'tab:brown',
    'tab:pink',
    'tab:olive',
)


def _figure(width=7.0, height=6.0):
    import matplotlib

    matplotlib.use('Agg', force=False)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=110)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path) -> str:
    path = str(path)
    with written_whole(path) as tmp:  # (its folder checked before the work: cli/range.py)
        fig.savefig(tmp, format='png', bbox_inches='tight')
    return path


def _hull_order(pts: np.ndarray) -> np.ndarray:
    c = pts.mean(axis=0)
    return pts[np.argsort(np.arctan2(pts[:, 1] - c[1], pts[:, 0] - c[0]))]


def draw_mechanism(
    ax,
    mech,
    points: Mapping[str, Any] | None = None,
    labels: bool = True,
    colour: str = 'k',
    alpha: float = 1.0,
) -> None:
    """Draw the mechanism on a matplotlib axes: links as bars / plates, cylinders as thick bars,
    slide lines dashed, ground pivots as triangles (``points`` defaults to the reference pose)."""
    pts = {k: np.asarray(v, float) for k, v in (points or mech.points).items()}
    ground = set(mech.links[mech.ground].points)
    cyl_links = set()
    for act in mech.actuators.values():
        if isinstance(act, SlideActuator) and act.cylinder:
            pj = mech.prismatics[act.joint]
            cyl_links |= {pj.guide, pj.slider}
            a, b = mech.links[pj.guide].points[0], mech.links[pj.slider].points[0]
            if a in pts and b in pts:
                ax.plot(
                    [pts[a][0], pts[b][0]],
                    [pts[a][1], pts[b][1]],
                    '-',
                    color='tab:gray',
                    lw=5,
                    alpha=0.6 * alpha,
                    solid_capstyle='round',
                    zorder=2,
                )
                ax.plot(
                    [pts[a][0], pts[b][0]],
                    [pts[a][1], pts[b][1]],
                    '-',
                    color='k',
                    lw=1,
                    alpha=alpha,
                    zorder=3,
                )
    for name, link in mech.links.items():
        if name == mech.ground or name in cyl_links:
            continue
        lp = np.array([pts[p] for p in link.points if p in pts])
        if len(lp) >= 3:
            poly = _hull_order(lp)
            ax.fill(poly[:, 0], poly[:, 1], color='tab:blue', alpha=0.15 * alpha, zorder=1)
            closed = np.vstack([poly, poly[:1]])
            ax.plot(closed[:, 0], closed[:, 1], '-', color=colour, lw=1.5, alpha=alpha, zorder=3)
        elif len(lp) == 2:
            ax.plot(lp[:, 0], lp[:, 1], '-', color=colour, lw=2, alpha=alpha, zorder=3)
    scale = mech.length_scale
    for pj in mech.prismatics.values():
        if pj.guide in cyl_links:
            continue
        if pj.point in pts:
            p = pts[pj.point]
            d = np.asarray(pj.direction) * 0.4 * scale
            ax.plot(
                [p[0] - d[0], p[0] + d[0]],
                [p[1] - d[1], p[1] + d[1]],
                '--',
                color='tab:gray',
                lw=1,
                alpha=alpha,
                zorder=1,
            )
    for name, p in pts.items():
        if name in ground:
            ax.plot(p[0], p[1], marker='^', color='k', ms=8, alpha=alpha, zorder=4)
        else:
            ax.plot(p[0], p[1], 'o', color='w', mec=colour, ms=5, alpha=alpha, zorder=4)
        if labels:
            ax.annotate(
                name,
                p,
                textcoords='offset points',
                xytext=(4, 4),
                fontsize=8,
                alpha=alpha,
                zorder=5,
            )


def plot_region(
    mech,
    region: Mapping[str, Any],
    path,
    title: str | None = None,
    show_cloud: bool = True,
    tilt: Mapping[str, Any] | None = None,
) -> str:
    """Reachable region of a point (from :func:`linkage_ros.core.motion.reachable_region`): the
    sampled cloud, the extreme arcs, the boundary and the mechanism in its reference pose.
    Returns the PNG path."""
    fig = _figure()
    ax = fig.add_subplot(1, 1, 1)
    cloud = np.asarray(region.get('cloud') or np.zeros((0, 2)), float).reshape(-1, 2)
    if show_cloud and cloud.size:
        ax.plot(
            cloud[:, 0],
            cloud[:, 1],
            '.',
            color='tab:cyan',
            ms=2,
            alpha=0.6,
            label=f'samples ({len(cloud)})',
            zorder=0,
        )
    for k, arc in enumerate(region.get('arcs') or []):
        p = np.asarray(arc['points'], float).reshape(-1, 2)
        if p.size:
            name, which, val = arc['fixed']
            ax.plot(
                p[:, 0],
                p[:, 1],
                '-',
                lw=2.2,
                color=_BRANCH_COLOURS[(k + 1) % 8],
                label=f'{name} at {which} ({val:.4g}), {arc["sweep"]} sweeps',
                zorder=2,
            )
    b = np.asarray(region.get('boundary') or np.zeros((0, 2)), float).reshape(-1, 2)
    if b.size:
        closed = np.vstack([b, b[:1]]) if region.get('method') != 'path' else b
        ax.plot(
            closed[:, 0],
            closed[:, 1],
            '-',
            color='tab:red',
            lw=0.9,
            label=f'boundary ({region.get("method")}), area {region.get("area", 0):.4g}',
            zorder=3,
        )
    draw_mechanism(ax, mech)
    if tilt and tilt.get('hold_point'):
        hp = tilt['hold_point']
        ax.plot(
            hp[0],
            hp[1],
            marker='*',
            color='tab:red',
            ms=12,
            zorder=6,
            label=f'{tilt.get("lip")} held',
        )
    pt = region.get('point')
    acts = ', '.join(region.get('actuators') or [])
    what = 'path' if region.get('method') == 'path' else 'region'
    ax.set_title(title or f'{mech.name}: {what} of {pt} ({acts})')
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.set_aspect('equal', adjustable='datalim')
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, loc='best')
    return _save(fig, path)


def _output_getter(mech, output: str):
    """(label, unit, is_angle, function(result) -> value) for an output name: a link (its
    angle), a joint, an actuator, or a point coordinate 'P.x' / 'P.y'."""
    coordinate = point_coordinate(mech, output)
    if coordinate is not None:
        p, i = coordinate
        return output, 'm', False, lambda r: r.points[p][i] if p in r.points else math.nan
    try:
        named = resolve_name(mech, output)  # the one rule (model.names), as the solver's knowns
    except PlanError:
        named = None
    bare = named.name if named is not None else ''
    match named.kind if named is not None else None:
        case NameKind.ACTUATOR:
            ang = isinstance(mech.actuators[bare], AngleActuator)
            return output, 'deg' if ang else 'm', ang, lambda r: r.inputs.get(bare, math.nan)
        case NameKind.JOINT:
            ang = bare not in mech.prismatics
            return (
                f'joint {bare}',
                'deg' if ang else 'm',
                ang,
                lambda r: r.joints.get(bare, math.nan),
            )
        case NameKind.LINK if bare != mech.ground:
            return f'{bare} angle', 'deg', True, lambda r: r.links.get(bare, math.nan)
    raise ValueError(
        f'unknown output {output!r}: give a link, joint, actuator or a point '
        f'coordinate such as {next(iter(mech.points))}.x'
    )


def _angle_window(values: np.ndarray) -> float:
    """Start of a 2 pi window that puts the largest circular gap of the angles at its ends."""
    v = np.sort(np.mod(values[np.isfinite(values)], 2 * math.pi))
    if v.size < 2:
        return 0.0
    gaps = np.diff(np.concatenate([v, [v[0] + 2 * math.pi]]))
    k = int(np.argmax(gaps))
    if gaps[k] < 0.05:  # the output turns fully: plot over [0, 360)
        return 0.0
    return float(v[(k + 1) % v.size] - 0.5 * min(gaps[k], 0.2))


def _traced_curves(
    free,
    input: str,
    others: dict,
    knowns: list,
    xs,
    lo: float,
    in_angle: bool,
    get,
    samples: int,
    curves: dict,
) -> bool:
    """The curves of a Newton-placed circuit from its trace (ranges.scan_circuit): each
    monotone stretch between the input's toggles swept in its loop-Jacobian mode from the
    trace's own configuration on it outward (the mode recurs on other stretches: a
    Stephenson-III six-bar driven at its output has four, two in each mode, and from the
    drawing a sweep in a mode found one of them). A mode's second stretch is keyed '<mode>
    #2'. False, adding nothing, where the circuit was not traced."""
    from .core.motion.quantities import BACK_TO_START, outward_order
    from .core.motion.ranges import scan_circuit
    from .core.solver import Solver

    _, _, segs, _ = scan_circuit(free, input, others, max(int(samples), 16))
    stretches = [(s, s.start) for s in segs if s.start is not None]
    if not stretches:
        return False
    # the sweep's grid is in the assembly's turn (actuator_range's); the trace's unwrapped
    shift = lo - min(s.lo for s, _ in stretches) if in_angle else 0.0
    ends = np.geomspace(1e-8, 1.0 / max(int(samples) - 1, 1), 12)
    seen: dict[str, int] = {}
    for s, start in stretches:
        a, b = s.lo + shift, s.hi + shift
        grid = np.unique(
            np.concatenate(
                [xs[(xs >= a) & (xs <= b)], [a, b], a + (b - a) * ends, b - (b - a) * ends]
            )
        )
        mode = start.branch
        seen[mode] = seen.get(mode, 0) + 1
        key = mode if seen[mode] == 1 else f'{mode} #{seen[mode]}'
        walker = Solver(free, knowns=knowns, branch=mode)
        walker.adopt(start)
        for i in outward_order(grid, s.seed + shift):
            if i == BACK_TO_START:
                walker.reset()
                walker.adopt(start)
                continue
            r = walker.solve({input: float(grid[i]), **others})
            if r.success and r.branch == mode:
                curves.setdefault(key, []).append((float(grid[i]), float(get(r))))
    for c in curves.values():
        c.sort()
    return True


def plot_output_vs_input(
    mech,
    input: str,
    output: str,
    path,
    samples: int = 721,
    held: Mapping[str, float] | None = None,
    title: str | None = None,
) -> dict:
    """Output versus input over the input's whole assembly range, one curve per assembly mode
    (branch), like the theta4-versus-theta2 figures of the four-bar with both branches. The
    other actuators are held at their reference values (or ``held``); the scene's limits on the
    input are drawn as dashed lines (the sweep itself ignores them). Angles in degrees.

    Returns {'path', 'input', 'output', 'branches': {label: {'input': [...], 'output': [...]}}}.
    """
    from .core.motion import actuator_range, reference_value, without_limits
    from .core.solver import SolveMode, Solver

    if input not in mech.actuators:
        raise ValueError(
            f'{input!r} is not an actuator of {mech.name!r}; actuators: {sorted(mech.actuators)}'
        )
    label, unit, is_angle, get = _output_getter(mech, output)
    act = mech.actuators[input]
    in_angle = isinstance(act, AngleActuator)
    info = actuator_range(mech, input, held=held)
    x0 = info['reference']
    asm = info.get('assembly')
    if in_angle:
        if info['full_turn'] or asm is None:
            lo, hi = 0.0, 2 * math.pi
        else:
            lo, hi = asm
    else:
        lo = (
            asm[0]
            if asm and asm[0] is not None
            else (act.min if act.min is not None else x0 - mech.length_scale)
        )
        hi = (
            asm[1]
            if asm and asm[1] is not None
            else (act.max if act.max is not None else x0 + mech.length_scale)
        )
    spans = [(lo, hi)]
    if in_angle and asm is not None and not info['full_turn'] and held is None:
        # the input's other circuits (a Grashof double-rocker's mirror loop, seed 000's second
        # curve): drawn beside the drawing's, the gap between them left open
        from .core.motion.other_circuits import other_circuits

        spans += other_circuits(mech, input)
    step = (hi - lo) / (max(int(samples), 2) - 1)
    parts = []
    for s_lo, s_hi in spans:
        part = np.linspace(s_lo, s_hi, max(int(round((s_hi - s_lo) / step)) + 1, 2))
        if (in_angle and asm is not None and not info['full_turn']) or (not in_angle and asm):
            # near a toggle the output moves like the square root of the input: densify ends
            fr = np.geomspace(1e-8, 1.0 / max(int(samples) - 1, 1), 12)
            part = np.concatenate([part, s_lo + (s_hi - s_lo) * fr, s_hi - (s_hi - s_lo) * fr])
        parts.append(part)
    xs = np.unique(np.concatenate(parts))
    others = {
        a: (held or {}).get(a, reference_value(mech, a)) for a in mech.actuators if a != input
    }
    free = without_limits(mech)
    knowns = [input] + list(others)
    solver = Solver(free, knowns=knowns, branch='reference')
    curves: dict[str, list[tuple[float, float]]] = {}
    if solver.mode is SolveMode.CLOSED_FORM:
        for x in xs:
            for r in solver.solve_all({input: float(x), **others}):
                if r.success:
                    key = r.branch or 'continuous'
                    curves.setdefault(key, []).append((float(x), float(get(r))))
    elif _traced_curves(free, input, others, knowns, xs, lo, in_angle, get, samples, curves):
        pass  # (Newton places it: every stretch of the traced circuit, _traced_curves)
    else:
        # Newton places it, untraced: each of the loop Jacobian's modes (J+, J-: the two halves
        # of a circuit between the input's toggles, an outside scene author's Stephenson
        # six-bar), followed from the drawing's input outward (quantities.outward_order)
        from .core.motion.quantities import BACK_TO_START, outward_order

        order = outward_order(xs, x0)
        for mode in ('J+', 'J-'):
            try:
                walker = Solver(free, knowns=knowns, branch=mode)
            except ValueError:  # (no Jacobian modes to name: the reference's curve alone)
                walker, mode = solver, ''
            for i in order:
                if i == BACK_TO_START:
                    walker.reset()
                    continue
                r = walker.solve({input: float(xs[i]), **others})
                if r.success and (not mode or r.branch == mode):
                    key = r.branch or 'continuous'
                    curves.setdefault(key, []).append((float(xs[i]), float(get(r))))
            if not mode:
                break
        for c in curves.values():
            c.sort()
    # at a toggle the assembly modes coincide (solve_all reports one): join every branch there
    for x in sorted({float(v) for span in spans for v in span}):
        at = {k: [v for xx, v in c if xx == x] for k, c in curves.items()}
        found = [v for vals in at.values() for v in vals]
        if len(curves) > 1 and len(found) == 1:
            for k, c in curves.items():
                if not at[k]:
                    c.append((float(x), found[0]))
                    c.sort()
    allv = np.array([v for c in curves.values() for _, v in c]) if curves else np.zeros(0)
    start = _angle_window(allv) if is_angle else 0.0
    fig = _figure(7.5, 5.0)
    ax = fig.add_subplot(1, 1, 1)
    out_branches = {}
    for n, (key, pts) in enumerate(sorted(curves.items())):
        a = np.array(pts)
        xin, yv = a[:, 0], a[:, 1]
        if is_angle:
            yv = start + np.mod(yv - start, 2 * math.pi)
        out_branches[key] = {'input': xin.tolist(), 'output': yv.tolist()}
        xp = np.degrees(xin) if in_angle else xin
        yp = np.degrees(yv) if is_angle else yv.copy()
        # break the line where it jumps (window wrap) or where the sweep skipped inputs
        jump = np.abs(np.diff(yp)) > (180.0 if is_angle else 0.25 * (np.ptp(yp) or 1.0))
        gap = np.diff(xin) > 1.5 * step
        cut = np.flatnonzero(jump | gap) + 1
        xp = np.insert(xp.astype(float), cut, np.nan)
        yp = np.insert(yp.astype(float), cut, np.nan)
        ax.plot(xp, yp, '-', lw=1.6, color=_BRANCH_COLOURS[n % 8], label=f'branch {key}')
    for v, name in ((act.min, 'min'), (act.max, 'max')):
        if v is not None:
            ax.axvline(math.degrees(v) if in_angle else v, ls='--', color='tab:gray', lw=1)
            ax.annotate(
                f'{input} {name}',
                (math.degrees(v) if in_angle else v, 0.02),
                xycoords=('data', 'axes fraction'),
                fontsize=7,
                rotation=90,
                color='tab:gray',
            )
    ax.set_xlabel(f'{input} ({"deg" if in_angle else "m"})')
    ax.set_ylabel(f'{label} ({unit})')
    modes = (
        'every assembly mode'
        if solver.mode is SolveMode.CLOSED_FORM
        else ("the drawing's circuit, each Jacobian mode")
    )
    ax.set_title(title or f'{mech.name}: {label} versus {input}, {modes}')
    ax.grid(True, lw=0.3)
    if curves:
        ax.legend(fontsize=8, loc='best')
    return {'path': _save(fig, path), 'input': input, 'output': output, 'branches': out_branches}


__all__ = ['plot_region', 'plot_output_vs_input', 'draw_mechanism']
