"""Motion limits: input ranges and toggles, reachable region of a point, tilt of a link, plots.

    linkage range SCENE [--json] [--point NAME [--actuators A,B] [--samples N]]
                        [--tilt LINK --lip POINT [--hold X,Y] [--tilt-from ANGLE]] [--links]
                        [--plot out.png] [--curves out.png --input NAME --output NAME]
                        [--motion]

Input ranges are found with the other actuators held at their reference-pose values (each bound
is a toggle of the assembly, refined to 1e-12 in closed form; where Newton places the scene, the
last value its solve closes to its tolerance, up to ~1e-10 past the toggle; or the scene's
limit). ``--point`` adds the region the point reaches while the actuators that move it run over
their limits in the drawing's assembly mode (a motion on through a dead centre into another
mode is not followed there; ``--links`` and ``--motion`` follow the input's circuit through
its toggles, as the lectures' range of oscillation does)
(the four extreme arcs for two actuators: area and extent to about 1e-9; else the
samples' concave hull, an estimate: it bridges notches narrower than 2.5 sample spacings and
fills holes, and its extent is the samples': measured off by 0.9 % (the excavator's L) to 37 %
(a folding map at the default --samples 41), a hole filled in whole; more --samples bring it
closer except over a hole); ``--tilt LINK --lip POINT`` the largest rotation of LINK about POINT
held at its reference position (or ``--hold X,Y``, from the link's angle ``--tilt-from``) within
the actuator limits; ``--links`` the oscillation range of every moving link of two points or
more; ``--plot`` draws the region (of ``--point``, else of the scene's first output point) and
``--curves`` an output versus an input with every assembly mode (where Newton places the
mechanism: the drawing's circuit in each loop-Jacobian mode, J+ and J-). Angles are radians
(degrees in parentheses), lengths metres.

JSON: {"scene" (the file, as linkage check's), "name", "inputs": {name: {"min", "max",
"min_source", "max_source", "full_turn", "assembly", "drawn" (the reference pose's value, as
linkage check's), "unit"}}, "toggles": {name: [...]}, "region": {point: {"boundary":
[[x, y], ...], "area", "extent", "method", "actuators", "limits", "hull_check"}}, "tilt": {...},
"oscillation": {"input", "links": {link: {"min", "max", "full_turn"[, "without_limits":
{...}: a limited crank's whole circuit]}}}, "motion": {"actuator",
"full_turn", "outputs": {...}, "transmission_angle": {...}} (``--motion``, as linkage check's,
and "motion_without_limits" likewise where a crank's limits stop short of its toggles),
"plots": {...}[, "without_limits": [actuator, ...]]}.

Exit status: 0 ok; 1 a requested analysis was refused (the tilt's start pose does not solve);
2 a usage error (bad option, unknown name, scene error).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from typing import Any

from ..core.errors import LinkageError
from ..core.model import SlideActuator
from ..core.units import Quantity, UnitError, degrees_warning, expect, parse_text
from ..outputs import folder_refusal, input_refusal
from .common import UsageError, add_scene_argument, file_name, load_mechanism
from .described import InputValues
from .process import say

OK, REFUSED, USAGE_ERROR = 0, 1, 2
PROG = 'linkage range'


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.description = (
        'Motion limits of a scene: input ranges and toggle positions, the region a '
        'point reaches, the tilt of a link about a held point, and plots.'
    )
    p.epilog = __doc__.split('\n', 2)[2].rstrip() + '\n'
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    add_scene_argument(p)
    p.add_argument('--json', action='store_true', help='machine-readable output')
    p.add_argument('--point', metavar='NAME', help='reachable region of this point')
    p.add_argument(
        '--actuators',
        metavar='A,B',
        help='actuators that run for the region (default: those that move the point)',
    )
    p.add_argument(
        '--samples',
        type=int,
        default=41,
        metavar='N',
        help='region grid samples per actuator (default 41, at least 3; the grid, samples to the '
        'power of the actuators, at most 4,000,000)',
    )
    p.add_argument('--tilt', metavar='LINK', help='largest rotation of LINK about --lip held')
    p.add_argument('--lip', metavar='POINT', help='point of the tilted link that is held')
    p.add_argument('--hold', metavar='X,Y', help='where the lip is held (default: reference)')
    p.add_argument(
        '--tilt-from',
        metavar='ANGLE',
        help="the tilted link's angle to start from (rad, or with a unit: --tilt-from=-45deg; "
        'default: its reference angle), with the lip held there',
    )
    p.add_argument(
        '--without-limits',
        metavar='A,B',
        help='actuators whose limits the analyses lift (a what-if: seed 003 states the '
        "excavator's Z1 and Z2 ranges only, and its tilt about the lip is K's zone's)",
    )
    p.add_argument(
        '--links',
        action='store_true',
        help='oscillation range of every moving link drawn with two points or more (first '
        'actuator, or --input); a one-point slider block turns with its guide and a '
        "cylinder's barrel and rod with their pins, so they are not listed",
    )
    p.add_argument(
        '--plot', type=file_name, metavar='PNG', help='draw the reachable region to this PNG'
    )
    p.add_argument(
        '--curves',
        type=file_name,
        metavar='PNG',
        help='draw --output versus --input, every assembly mode, to this PNG',
    )
    p.add_argument('--input', metavar='NAME', help='actuator for --curves / --links')
    p.add_argument(
        '--motion',
        action='store_true',
        help='one-actuator scenes: rocker swing / slider stroke with the input at their ends, '
        'time ratio, transmission angle extremes (as linkage check prints them)',
    )
    p.add_argument(
        '--output',
        metavar='NAME',
        help='link (angle), joint, actuator or point coordinate P.x / P.y for --curves',
    )


def _fmt(v, unit=''):
    if v is None:
        return 'none'
    s = f'{v:.9g}'
    if unit == 'rad':
        s += f' rad ({math.degrees(v):.4g} deg)'
    elif unit:
        s += f' {unit}'
    return s


#: the most configurations a --point region's grid solves (about 0.2 kB each while solved)
MAX_REGION_SAMPLES = 4_000_000


def _check(args, mech, scene_file: str):
    if (args.tilt is None) != (args.lip is None):
        raise UsageError('--tilt LINK and --lip POINT go together')
    if (args.hold or args.tilt_from) and args.tilt is None:
        raise UsageError('--hold and --tilt-from need --tilt and --lip')
    if args.curves and not args.output:
        raise UsageError(
            '--curves needs --output NAME (and --input NAME when there are several actuators)'
        )
    if args.input is not None and args.input not in mech.actuators:
        raise UsageError(
            f'--input {args.input!r} is not an actuator of {mech.name!r} '
            f'({", ".join(mech.actuators)})'
        )
    if args.curves and args.input is None and len(mech.actuators) > 1:
        raise UsageError(
            f'--curves needs --input NAME: {mech.name!r} has actuators {", ".join(mech.actuators)}'
        )
    if args.point is not None and args.point not in mech.points:
        raise UsageError(
            f'--point {args.point!r} is not a point of {mech.name!r} ({", ".join(mech.points)})'
        )
    if args.samples < 3:
        raise UsageError(f'--samples must be at least 3 (got {args.samples})')
    if args.point is not None or args.plot:
        k = len(args.actuators.split(',')) if args.actuators else len(mech.actuators)
        if args.samples**k > MAX_REGION_SAMPLES:
            # (--samples 10^8 took 12 GB in a minute before: an adversary)
            raise UsageError(
                f'--samples {args.samples}: the region grid over {k} actuator(s) would be '
                f'{args.samples}^{k} = {args.samples**k:,} configurations, more than '
                f'{MAX_REGION_SAMPLES:,}'
            )
    for option, path in (('--plot', args.plot), ('--curves', args.curves)):
        # (the scene file as loaded: a packaged scene's name is no path to compare)
        why = (folder_refusal(path) or input_refusal(path, [scene_file])) if path else None
        if why:  # before the analysis, as --csv and the bag's outputs: no run lost at its end
            raise UsageError(f'{option} {path}: {why}')
    acts = None
    if args.actuators:
        acts = [a.strip() for a in args.actuators.split(',') if a.strip()]
        bad = [a for a in acts if a not in mech.actuators]
        if bad:
            raise UsageError(f'--actuators: {bad} not actuator(s) of {mech.name!r}')
        twice = sorted({a for a in acts if acts.count(a) > 1})
        if twice:
            raise UsageError(f'--actuators: {", ".join(twice)} named more than once')
        if args.point is None and not args.plot:
            raise UsageError('--actuators needs --point (or --plot)')
    hold = None
    if args.hold:
        try:
            hold = [float(v) for v in args.hold.split(',')]
        except ValueError:
            hold = []
        if len(hold) != 2 or not all(math.isfinite(v) for v in hold):
            raise UsageError(f'--hold must be X,Y (two numbers), got {args.hold!r}')
    return acts, hold


def _swing(lo: float | None, hi: float | None) -> dict[str, Any]:
    """A link's oscillation as the report gives it (lo None: it turns fully)."""
    return {'min': lo, 'max': hi, 'full_turn': lo is None}


def _swing_text(v: dict[str, Any]) -> str:
    if v['full_turn']:
        return 'turns fully'
    return (
        f'{_fmt(v["min"], "rad")} .. {_fmt(v["max"], "rad")} '
        f'(swing {math.degrees(v["max"] - v["min"]):.4g} deg)'
    )


def _tilt_from(args) -> float | None:
    """--tilt-from in rad (the unit grammar of core.units: a bare number is rad)."""
    if args.tilt_from is None:
        return None
    try:
        reading = expect(parse_text(args.tilt_from), Quantity.ANGLE)
    except UnitError as exc:
        raise UsageError(f'--tilt-from {args.tilt_from!r} {exc}') from None
    warning = degrees_warning('--tilt-from', reading)
    if warning:
        print(f'warning: {warning}', file=sys.stderr)
    return reading.value


def analyse(args, mech, scene_file: str) -> tuple[dict, int]:
    """Run the requested analyses; returns (report dict of plain data, exit status)."""
    from ..core import motion
    from ..core.motion.quantities import link_swings

    acts, hold = _check(args, mech, scene_file)
    report: dict[str, Any] = {
        'name': mech.name,
        'dof': mech.dof,
        'actuators': list(mech.actuators),
        'inputs': {},
        'toggles': {},
    }
    status = OK
    for name, info in motion.actuator_ranges(mech).items():
        report['inputs'][name] = {
            k: info[k]
            for k in (
                'kind',
                'unit',
                'min',
                'max',
                'min_source',
                'max_source',
                'full_turn',
                'assembly',
            )
        }
        report['inputs'][name]['drawn'] = info['reference']
        report['toggles'][name] = info['toggles']
    region_point = args.point or (mech.outputs[0] if args.plot and mech.outputs else None)
    if args.plot and region_point is None:
        raise UsageError('--plot needs --point NAME (the scene names no output point)')
    if region_point is not None:
        reg = motion.reachable_region(
            mech, region_point, samples_per_actuator=args.samples, actuators=acts
        )
        report['region'] = {
            region_point: {
                k: reg[k]
                for k in (
                    'boundary',
                    'area',
                    'extent',
                    'method',
                    'actuators',
                    'limits',
                    'held',
                    'hull_check',
                )
            }
        }
        region_full = reg
    if args.tilt is not None:
        try:
            tilt = motion.max_tilt(
                mech, args.lip, args.tilt, hold_point=hold, start_angle=_tilt_from(args)
            )
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        report['tilt'] = tilt
        if not tilt.get('ok'):
            status = REFUSED
    if args.links:
        inp = args.input or next(iter(mech.actuators))
        osc: dict[str, dict[str, Any]] = {}
        cyl = {
            l
            for a in mech.actuators.values()
            if isinstance(a, SlideActuator) and a.cylinder
            for l in (mech.prismatics[a.joint].guide, mech.prismatics[a.joint].slider)
        }
        free = motion.input_limits_lifted(mech, inp)  # (None: the input has no limits)
        links = [
            link
            for link in mech.moving_links
            if link not in cyl and len(mech.links[link].points) >= 2
        ]
        try:
            swings = link_swings(mech, links, inp)
            # the lectures' question ("through what angle can link 4 oscillate") is the whole
            # circuit, through the toggles the limits keep the input short of
            lifted = {} if free is None else link_swings(free, links, inp)
        except ValueError as exc:
            raise UsageError(f'--links: {exc}') from None
        for link in links:
            osc[link] = _swing(*swings[link])
            if link in lifted:
                osc[link]['without_limits'] = _swing(*lifted[link])
        report['oscillation'] = {'input': inp, 'links': osc}
    if args.motion:
        from ..core.motion.quantities import quantities_report

        if len(mech.actuators) != 1:
            raise UsageError(
                f'--motion needs a scene with one actuator ({mech.name!r} has '
                f'{len(mech.actuators)})'
            )
        from .check import through_toggles

        report['motion'] = quantities_report(mech)
        free_mech = motion.input_limits_lifted(mech, next(iter(mech.actuators)))
        whole = through_toggles(report['motion'], free_mech)
        if whole is not None:
            report['motion_without_limits'] = whole
    plots = {}
    if args.plot:
        from ..plots import plot_region

        plots['region'] = plot_region(mech, region_full, args.plot, tilt=report.get('tilt'))
    if args.curves:
        from ..plots import plot_output_vs_input

        inp = args.input or next(iter(mech.actuators))
        try:
            d = plot_output_vs_input(mech, inp, args.output, args.curves)
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        plots['curves'] = d['path']
    if plots:
        report['plots'] = plots
    return report, status


def _print_human(r: dict, mech) -> None:
    p = say
    p(
        f'{r["name"]}: {r["dof"]} DOF, actuators {", ".join(r["actuators"])}'
        + (' (each range with the others held at the reference pose)' if r['dof'] > 1 else '')
    )
    if r.get('without_limits'):
        p(f'limits lifted (--without-limits): {", ".join(r["without_limits"])}')
    p('input ranges:')
    for name, i in r['inputs'].items():
        unit = i['unit']
        if i['min'] is None and i['max'] is None:
            text = 'full turn, no limits' if i['full_turn'] else 'no bound found'
        else:
            text = f'{_fmt(i["min"], unit)} .. {_fmt(i["max"], unit)}'
            text += f'  [min: {i["min_source"] or "open"}, max: {i["max_source"] or "open"}]'
        if i['full_turn'] and i['min'] is not None:
            text += '  (the assembly turns fully)'
        elif (
            i['assembly']
            and i['min_source'] == 'limit'
            and i['max_source'] == 'limit'
            and None not in i['assembly']
        ):
            a = i['assembly']
            text += f'  (assembly {a[0]:.9g} .. {a[1]:.9g} {unit})'
        p(f'  {name:<10} {i["kind"]:<6} {text}')
    p('toggle positions:')
    for name, t in r['toggles'].items():
        unit = r['inputs'][name]['unit']
        p(f'  {name:<10} ' + (', '.join(_fmt(v, unit) for v in t) if t else 'none'))
    for pt, reg in (r.get('region') or {}).items():
        b = reg['boundary']
        (x0, x1), (y0, y1) = reg['extent'] or [[0.0, 0.0], [0.0, 0.0]]
        p(
            f'region of {pt} ({", ".join(reg["actuators"]) or "no actuator moves it"}): '
            f'{reg["method"]}, area {reg["area"]:.6g} m^2, {len(b)} boundary vertices, '
            f'x {x0:.6g} .. {x1:.6g} m, y {y0:.6g} .. {y1:.6g} m'
        )
        for a, lim in reg['limits'].items():
            p(f'  {a} over {lim[0]:.9g} .. {lim[1]:.9g}')
        hc = reg['hull_check']
        if reg['method'] == 'concave_hull':
            p(
                '  boundary: the concave hull of the samples, an estimate: it bridges notches '
                'narrower than 2.5 sample spacings and fills holes, and its extent is the '
                "samples' (with a closed-form plan, and the edges where the mechanism stops "
                'assembling between two: a dead centre inside the limits); its area may be off '
                'by a few % (measured: excavator L 0.9 %, a crane whose fold cylinder has its '
                'dead centre inside its limits 0.8 %), by '
                'tens of % where the map folds at few samples (--samples brings it closer), '
                'or by a whole hole'
            )
        if reg['method'] == 'concave_hull' and hc.get('outside'):
            p(
                f'  the extreme arcs do not enclose the samples ({hc["outside"]} outside by up to '
                f'{hc["max_outside"]:.3g} m): the map folds; boundary from the samples'
            )
    t = r.get('tilt')
    if t is not None:
        hp = t['hold_point']
        if not t.get('ok'):
            p(
                f'tilt of {t["link"]} about {t["lip"]} held at ({hp[0]:.6g}, {hp[1]:.6g}): '
                f'refused at the start: {t["reason"].get("start")}'
            )
        else:
            p(
                f'tilt of {t["link"]} about {t["lip"]} held at ({hp[0]:.6g}, {hp[1]:.6g}), '
                f'starting at {_fmt(t["start"], "rad")}:'
            )
            for key, word in (('max', 'up (counter-clockwise)'), ('min', 'down (clockwise)')):
                amount = t['tilt_up'] if key == 'max' else t['tilt_down']
                if t[key] is None:
                    p(f'  {word}: no limit within half a turn')
                else:
                    p(
                        f'  {word}: {_fmt(amount, "rad")} to {_fmt(t[key], "rad")}; '
                        f'limited by: {t["reason"][key]}'
                    )
    o = r.get('oscillation')
    if o is not None:
        p(f'link oscillation while {o["input"]} runs over its range:')
        for link, v in o['links'].items():
            text = _swing_text(v)
            free = v.get('without_limits')
            if free is not None and free != _swing(v['min'], v['max']):
                text += f"; without the input's limits (through its toggles): {_swing_text(free)}"
            p(f'  {link:<12} {text}')
    if r.get('motion') is not None:
        from .check import format_motion

        for line in format_motion(r['motion'], r.get('motion_without_limits')):
            p(line)
    for k, v in (r.get('plots') or {}).items():
        p(f'wrote {k} plot: {v}')


def described(report: dict, mech) -> dict:
    """The report's actuator names and values in a robot description's own (its joint names
    and values, as joint_states publishes them); a scene's report is left as it is."""
    values = InputValues(mech)
    if values.jm is None:
        return report
    name = values.name
    report['actuators'] = [name(a) for a in report['actuators']]
    inputs = {}
    for act, i in report['inputs'].items():
        i = dict(i)
        i['min'], i['max'] = values.interval(act, i['min'], i['max'])
        if values.reversed(act):
            i['min_source'], i['max_source'] = i['max_source'], i['min_source']
        if i.get('assembly'):
            i['assembly'] = list(values.interval(act, *i['assembly']))
        i['drawn'] = values.value(act, i['drawn'])
        inputs[name(act)] = i
    report['inputs'] = inputs
    report['toggles'] = {name(a): values.values(a, t) for a, t in report['toggles'].items()}
    for reg in (report.get('region') or {}).values():
        reg['limits'] = {name(a): list(values.interval(a, *v)) for a, v in reg['limits'].items()}
        reg['held'] = {name(a): values.value(a, v) for a, v in reg['held'].items()}
        reg['actuators'] = [name(a) for a in reg['actuators']]
    if report.get('oscillation'):
        report['oscillation']['input'] = name(report['oscillation']['input'])
    if report.get('motion'):
        from .check import described_motion

        report['motion'] = described_motion(report['motion'], values)
        if report.get('motion_without_limits'):
            report['motion_without_limits'] = described_motion(
                report['motion_without_limits'], values
            )
    return report


def run(args) -> int:
    try:
        mech, _path = load_mechanism(args.scene, args.dimension, args.closures, args.actuated)
        values = InputValues(mech)  # a robot description's actuated joints name its actuators
        if args.input is not None:
            args.input = values.actuator(args.input)
        if args.actuators:
            args.actuators = ','.join(values.actuator(a.strip()) for a in args.actuators.split(','))
        lifted = []
        if args.without_limits:
            lifted = [values.actuator(a.strip()) for a in args.without_limits.split(',')]
            unknown = [a for a in lifted if a not in mech.actuators]
            if unknown:
                raise UsageError(
                    f'--without-limits {", ".join(unknown)}: not an actuator of {mech.name!r} '
                    f'({", ".join(mech.actuators)})'
                )
            from ..core.motion import limits_lifted

            mech = limits_lifted(mech, lifted)
        report, status = analyse(args, mech, _path)
        report = {'scene': _path, **report}  # (the file first, as linkage check's JSON)
        if lifted:
            report['without_limits'] = [values.name(a) for a in lifted]
        report = described(report, mech)
    except UsageError as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return USAGE_ERROR
    except LinkageError as exc:
        print(f'{PROG}: error: {exc}', file=sys.stderr)
        return USAGE_ERROR
    if args.json:
        say(json.dumps(report, indent=2, allow_nan=False, default=float))
    else:
        _print_human(report, mech)
    return status


def main(argv: Sequence[str] | None = None) -> int:
    """Stand-alone entry point: ``python -m linkage_ros.cli.range ...``."""
    from .standalone import standalone_main

    return standalone_main(PROG, add_arguments, run, argv)


if __name__ == '__main__':
    sys.exit(main())
