"""One benchmark run: machine state, every measurement, and the targets evaluated."""

from __future__ import annotations

import datetime
import os
import platform
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .all_outputs import PLAIN_LISTENER_LABEL
from .core_speed import bench_core_speed, core_speed_targets
from .fleet import bench_fleet, fleet_targets
from .ros_latency import NODE_PARTS, bench_node
from .scaling import bench_scaling, scaling_targets
from .settings import (
    NODE_CPU_BASELINE_COMMIT,
    NODE_CPU_BASELINE_US,
    REF_DPS,
    SCENES,
    TARGET_LATENCY_MS,
    TARGET_NEWTON_BATCH_VS_SCIPY,
    TARGET_NEWTON_VS_SCIPY,
    TARGET_NODE_CPU_RATIO,
    TARGET_RATE_HZ,
    FloodKind,
    SettingFamily,
    Sizes,
    log,
)
from .throughput import bench_outputs, bench_throughput
from .tradeoff import bench_scene

# =============================================================================================
# the whole run and the report
# =============================================================================================


def machine_info() -> dict:
    cpu = ''
    try:
        for line in Path('/proc/cpuinfo').read_text().splitlines():
            if line.startswith('model name'):
                cpu = line.split(':', 1)[1].strip()
                break
    except OSError:
        pass
    import scipy

    try:
        import mpmath

        mpv = mpmath.__version__
    except ImportError:
        mpv = None
    try:  # numpy's SIMD dispatch: its vectorised maths differs with these, so do the ratios
        from numpy._core._multiarray_umath import __cpu_features__

        simd = [k for k in ('AVX2', 'FMA3', 'AVX512F', 'AVX512_SKX') if __cpu_features__.get(k)]
    except ImportError:
        simd = None
    return {
        'nproc': os.cpu_count(),
        'loadavg': [round(v, 2) for v in os.getloadavg()],
        'simd': simd,
        'affinity': len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else None,
        'cpu': cpu or platform.processor() or platform.machine(),
        'python': platform.python_version(),
        'numpy': np.__version__,
        'scipy': scipy.__version__,
        'mpmath': mpv,
        'platform': platform.platform(),
    }


def _cpu_seconds() -> tuple[float | None, float]:
    """(busy CPU seconds of the whole machine since boot or None, CPU seconds of this process
    and its waited-for children)."""
    t = os.times()
    own = t.user + t.system + t.children_user + t.children_system
    try:
        with open('/proc/stat') as fh:
            f = [float(v) for v in fh.readline().split()[1:]]
        busy = (sum(f[:8]) - f[3] - f[4]) / os.sysconf('SC_CLK_TCK')  # minus idle, iowait
    except (OSError, ValueError, IndexError):
        busy = None
    return busy, own


def code_version() -> str | None:
    """'<commit>' of the checkout, plus the modified package files if any (None outside git)."""
    root = Path(__file__).resolve().parents[2]
    try:
        head = subprocess.run(
            ['git', 'rev-parse', '--short', 'HEAD'],
            cwd=root,
            text=True,
            capture_output=True,
            timeout=10,
        )
        dirty = subprocess.run(
            ['git', 'status', '--porcelain', '--untracked-files=no', '--', 'linkage_ros', 'config'],
            cwd=root,
            text=True,
            capture_output=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return None
    if head.returncode != 0:
        return None
    changed = [line[3:] for line in dirty.stdout.splitlines() if line.strip()]
    return head.stdout.strip() + (
        f' + uncommitted changes in {", ".join(changed)}'
        if changed
        else ' (package files unmodified)'
    )


#: the measurements ``collect`` can run (``linkage bench --cases``)
CASES = (
    'tradeoff',
    'throughput',
    'core_speed',
    'outputs',
    'scaling',
    *(f'node_{p}' for p in NODE_PARTS),
    'fleet',
)


def collect(
    sizes: Sizes, scenes: Sequence[str] = SCENES, node: bool = True, cases: Sequence[str] = CASES
) -> dict:
    """Run the measurements ``cases`` names (every one by default); returns the report as
    plain data."""
    t_start = time.perf_counter()
    cpu0 = _cpu_seconds()
    report: dict[str, Any] = {
        'date': datetime.datetime.now().astimezone().isoformat(timespec='seconds'),
        'machine': machine_info(),
        'code': code_version(),
        'sizes': sizes.__dict__ | {},
        'settings': [],
        'scenes': {},
        'cases': list(cases),
        'throughput': [],  # the measurements not chosen stay empty
        'outputs': [],
    }
    for name in scenes if 'tradeoff' in cases else ():
        t0 = time.perf_counter()
        log(f'scene {name}: solver settings and the {REF_DPS}-digit reference')
        rows, info = bench_scene(name, sizes)
        info['seconds'] = time.perf_counter() - t0
        report['settings'] += [r.as_dict() for r in rows]
        report['scenes'][name] = info
    if 'throughput' in cases:
        log('four-bar throughput vs the numpy circle-intersection baseline')
        report['throughput'] = bench_throughput(sizes)
    if 'core_speed' in cases:
        log('solver core vs hand-written math / numpy four-bars and scipy root')
        report['core_speed'] = bench_core_speed(sizes)
    if 'outputs' in cases:
        log('excavator: one output vs all')
        report['outputs'] = bench_outputs(sizes)
    if 'scaling' in cases:
        log('big scenes: independent four-bars on one ground, time per actuator')
        report['scaling'] = bench_scaling(sizes.scaling)
    parts = [p for p in NODE_PARTS if f'node_{p}' in cases]
    if node and parts:
        report['node'] = bench_node(sizes, parts=parts)
    else:
        report['node'] = {'skipped': '--no-node given' if not node else 'no node case chosen'}
    report['fleet'] = bench_fleet(sizes) if 'fleet' in cases else {'skipped': 'not chosen'}
    report['targets'] = evaluate_targets(report)
    report['seconds'] = time.perf_counter() - t_start
    report['loadavg_end'] = [round(v, 2) for v in os.getloadavg()]
    cpu1 = _cpu_seconds()
    # CPU used by everything else on the machine while the benchmark ran, in cores
    report['other_cpu_cores'] = (
        None
        if cpu0[0] is None or cpu1[0] is None
        else max(0.0, ((cpu1[0] - cpu0[0]) - (cpu1[1] - cpu0[1])) / report['seconds'])
    )
    return report


def batch_vs_scipy(nw: dict[str, Any], sp: dict[str, Any]) -> tuple[float, str]:
    """The batched Newton's speed-up over scipy root per solve, and what it was measured
    against: the pairs timed together (tradeoff._newton_batch's batch_vs_scipy), else (a dump
    from before they were) the scalar sweep's scipy median, timed in another phase."""
    paired = nw.get('batch_vs_scipy')
    if paired:
        return float(paired), 'root over the same inputs, each batch paired with a scipy sweep'
    return sp['scalar_us'] / nw['batch_us'], f'{sp["scalar_us"]:.0f} us'


def find_setting(report, scene, family: SettingFamily, tol=None):
    for r in report['settings']:
        if r['scene'] == scene and r['family'] == family and (tol is None or r['tol'] == tol):
            return r
    return None


def evaluate_targets(report: dict) -> list[dict]:
    out = []
    # (a) vectorised four-bar at or above the numpy baseline, at every size measured. The
    # four-bar's vectorised solver is core.fourbar; Solver.solve_batch (any mechanism, every
    # point and joint) is reported in the throughput table, not held to this target.
    for row in report.get('throughput') or []:
        k = 'fourbar_forward'
        ratio = row['ratio_vs_baseline'][k]
        out.append(
            {
                'target': f'vectorised four-bar ({k}) at or above the numpy baseline '
                f'(n = {row["n"]:,})',
                'measured': f'{ratio:.2f}x the baseline throughput '
                f'({row["rate"][k] / 1e6:.2f} vs '
                f'{row["rate"]["numpy baseline"] / 1e6:.2f} M inputs/s)',
                'met': ratio >= 1.0,
                'value': ratio,
            }
        )
    # (b) Newton 1e-12 >= 20x faster than scipy root per solve
    for scene in report['scenes']:
        nw = find_setting(report, scene, SettingFamily.NEWTON, 1e-12)
        sp = find_setting(report, scene, SettingFamily.SCIPY, 1e-12)
        kn = find_setting(report, scene, SettingFamily.KERNEL, 1e-12)
        if nw and sp and nw['scalar_us'] and sp['scalar_us']:
            ratio = sp['scalar_us'] / nw['scalar_us']
            kr = sp['scalar_us'] / kn['scalar_us'] if kn and kn['scalar_us'] else None
            out.append(
                {
                    'target': f'{scene}: warm-started Newton 1e-12 >= '
                    f'{TARGET_NEWTON_VS_SCIPY:g}x faster than scipy root',
                    'measured': f'{ratio:.1f}x (Solver.solve {nw["scalar_us"]:.0f} us vs '
                    f'scipy {sp["scalar_us"]:.0f} us; kernel alone '
                    + (f'{kr:.1f}x)' if kr else 'n/a)'),
                    'met': ratio >= TARGET_NEWTON_VS_SCIPY,
                    'value': ratio,
                }
            )
        if nw and sp and nw.get('batch_us') and sp['scalar_us']:
            ratio, against = batch_vs_scipy(nw, sp)
            out.append(
                {
                    'target': f'{scene}: warm-started Newton 1e-12 vectorised over '
                    f'{nw["n"]} instances >= {TARGET_NEWTON_BATCH_VS_SCIPY:g}x faster '
                    'per solve than scipy root',
                    'measured': f'{ratio:.1f}x (Solver.solve_batch(start=) '
                    f'{nw["batch_us"]:.1f} us per solve vs scipy {against}; '
                    f'{nw["batch_careful"]} of {nw["n"]} rows took the careful path)',
                    'met': ratio >= TARGET_NEWTON_BATCH_VS_SCIPY,
                    'value': ratio,
                }
            )
    if report.get('core_speed'):
        out.extend(core_speed_targets(report['core_speed']))
    out.extend(scaling_targets(report.get('scaling') or []))
    # (c) node latency and rate
    node = report.get('node', {})
    tg = node.get('targets', {})
    rl, nd = tg.get('relay', {}), tg.get('node', {})
    if node.get('skipped'):
        out.append(
            {
                'target': 'node latency / rate',
                'measured': f'skipped: {node["skipped"]}',
                'met': None,
            }
        )
    elif rl.get('ok') and nd.get('ok'):
        r0, n0 = rl.get('latency', {}), nd.get('latency', {})
        if r0.get('p50_ms') is not None and n0.get('p50_ms') is not None:
            d = n0['p50_ms'] - r0['p50_ms']
            out.append(
                {
                    'target': f'node p50 latency within {TARGET_LATENCY_MS} ms of the bare '
                    'relay (paired ping-pong)',
                    'measured': f'{d:+.3f} ms (node p50 {n0["p50_ms"]:.3f} ms, relay '
                    f'{r0["p50_ms"]:.3f} ms; p99 node {n0["p99_ms"]:.3f} ms, '
                    f'relay {r0["p99_ms"]:.3f} ms)',
                    'met': d <= TARGET_LATENCY_MS,
                    'value': d,
                }
            )
        at = next((r for r in nd['runs'] if r['rate'] == TARGET_RATE_HZ), None)
        sr, rr = nd.get('sustained_rate'), rl.get('sustained_rate')
        if at is not None:
            met = at['lost'] == 0 and at['achieved_rate'] >= 0.95 * at['rate']
            out.append(
                {
                    'target': f'node sustains {TARGET_RATE_HZ:g} Hz with zero loss',
                    'measured': f'{at["lost"]} lost of {at["sent"]} at {at["rate"]:g} Hz '
                    f'(achieved send rate {at["achieved_rate"]:.0f} Hz); highest '
                    f'loss-free rate: node {rate_text(sr)}, relay {rate_text(rr)}',
                    'met': met,
                    'value': at['lost'],
                }
            )
        out.extend(flood_targets(nd.get('floods', [])))
        deep = tg.get('node_deep', {})
        at = next((r for r in deep.get('runs', []) if r['rate'] == TARGET_RATE_HZ), None)
        if at is not None:
            met = at['lost'] == 0 and at['achieved_rate'] >= 0.95 * at['rate']
            rd = tg.get('relay_deep', {})
            rat = next((r for r in rd.get('runs', []) if r['rate'] == TARGET_RATE_HZ), None)
            out.append(
                {
                    'target': f'node sustains {TARGET_RATE_HZ:g} Hz with zero loss, '
                    f'queue_depth {deep.get("depth")} (the same run, both targets '
                    'with the deeper queue)',
                    'measured': f'{at["lost"]} lost of {at["sent"]} at {at["rate"]:g} Hz '
                    f'(achieved send rate {at["achieved_rate"]:.0f} Hz); relay '
                    + (f'{rat["lost"]} lost of {rat["sent"]}' if rat else 'not measured'),
                    'met': met,
                    'value': at['lost'],
                }
            )
        out.extend(_all_outputs_targets(node))
    else:
        why = '; '.join(f'{k}: {v.get("reason")}' for k, v in tg.items() if not v.get('ok'))
        out.append(
            {'target': 'node latency / rate', 'measured': f'not measured: {why}', 'met': None}
        )
    out.extend(fleet_targets(report))
    return out


def _gap(run: dict) -> str:
    g = run.get('max_gap_ms')
    return (
        'largest gap between answers -'
        if g is None
        else (f'largest gap between answers {g:.0f} ms')
    )


def flood_targets(floods: list[dict]) -> list[dict]:
    """Commands beside floods: none lost beside the small new-name flood; beside the 2 MB
    flood, lost and p99 within 2x of the small new-name flood's; beside the 10 Hz 10^4-point
    trajectories, within 2x of the run without a flood (the same node, just before)."""
    runs = {FloodKind(fl['flood_kind']): fl for fl in floods}
    what = {
        FloodKind.NEW_SETS: 'hostile ~/target requests, each naming a new set of names',
        FloodKind.HUGE: 'hostile ~/target requests, each with 10^5 names, 2 MB',
        FloodKind.TRAJECTORY: '~/trajectory requests of 10^4 points each',
    }
    refs = {FloodKind.HUGE: FloodKind.NEW_SETS, FloodKind.TRAJECTORY: FloodKind.NONE}
    out: list[dict] = []
    for kind, fl in runs.items():
        if kind is FloodKind.NONE:
            continue
        if fl.get('ok') is False:
            out.append(
                {
                    'target': f'commands beside a {kind} flood',
                    'measured': f'not measured: {fl.get("reason")}',
                    'met': None,
                }
            )
            continue
        worker = fl.get('target_children_cpu_ms')
        measured = (
            f'{fl["lost"]} lost of {fl["sent"]} commands, p99 {_fmt_ms_plain(fl["p99_ms"])} '
            f'(achieved send rate {fl["achieved_rate"]:.0f} Hz; {fl["flood_sent"]} flood '
            f'requests; {_gap(fl)}'
            + ('' if worker is None else f'; the plan worker used {worker:.0f} ms of CPU')
            + ')'
        )
        sent_ok = fl['achieved_rate'] >= 0.95 * fl['rate']
        ref = runs.get(refs[kind]) if kind in refs else None
        if ref is None:
            target = (
                f'node loses no ~/command answer at {fl["rate"]:g} Hz beside a '
                f'{fl["flood_rate"]:g} Hz flood of {what.get(kind, kind)}'
            )
            met = fl['lost'] == 0 and sent_ok
        else:
            name = (
                'the run without a flood'
                if ref['flood_kind'] == FloodKind.NONE
                else ('the small new-name flood')
            )
            target = (
                f'commands lost and command p99 at {fl["rate"]:g} Hz beside a '
                f'{fl["flood_rate"]:g} Hz flood of {what.get(kind, kind)} within 2x of {name}'
            )
            measured += (
                f'; {name}: {ref["lost"]} lost, p99 {_fmt_ms_plain(ref["p99_ms"])}, {_gap(ref)}'
            )
            p99, ref_p99 = fl.get('p99_ms'), ref.get('p99_ms')
            met = (
                sent_ok
                and fl['lost'] <= 2 * ref['lost']
                and p99 is not None
                and ref_p99 is not None
                and p99 <= 2 * ref_p99
            )
        out.append({'target': target, 'measured': measured, 'met': met, 'value': fl['lost']})
    return out


def _fmt_ms_plain(v) -> str:
    return '-' if v is None else f'{v:.2f} ms'


def _all_outputs_targets(node: dict) -> list[dict]:
    """Every output subscribed: the node answers every command at the rate, as the relay in the
    same run does, with its p50 latency within TARGET_LATENCY_MS of the relay's."""
    out: list[dict] = []
    rate = node.get('all_outputs_rate')
    for scene, res in (node.get('all_outputs') or {}).items():
        nd, rl = res.get('node', {}), res.get('relay', {})
        if not nd.get('ok'):
            why = nd.get('reason', 'not run')
            out.append(
                {
                    'target': f'{scene}, every output on: node loses nothing at {rate:g} Hz',
                    'measured': f'not measured: {why}',
                    'met': None,
                }
            )
            continue
        relay = f'relay {rl["lost"]} lost' if rl.get('ok') else 'relay not measured'
        statuses = sum(v for k, v in nd.get('outputs', {}).items() if k.endswith('/status'))
        out.append(
            {
                'target': f'{scene}, every output on (points, markers, status, diagnostics '
                f'subscribed): node answers every command at {rate:g} Hz',
                'measured': f'{nd["lost"]} lost of {nd["sent"]} ({relay}; achieved send rate '
                f'{nd["achieved_rate"]:.0f} Hz; {statuses} statuses received; {_gap(nd)})',
                'met': nd['lost'] == 0
                and statuses == nd['sent']
                and nd['achieved_rate'] >= 0.95 * nd['rate'],
                'value': nd['lost'],
            }
        )
        plain = res.get(PLAIN_LISTENER_LABEL, {})
        if plain.get('ok'):
            statuses = sum(v for k, v in plain.get('outputs', {}).items() if k.endswith('/status'))
            out.append(
                {
                    'target': f'{scene}, every output on, a plain rclpy listener '
                    '(SingleThreadedExecutor, raw subscriptions, its own process): node '
                    f'answers every command at {rate:g} Hz',
                    'measured': f'{plain["lost"]} lost of {plain["sent"]} (achieved send rate '
                    f'{plain["achieved_rate"]:.0f} Hz; {statuses} statuses received; '
                    f'{_gap(plain)})',
                    'met': plain['lost'] == 0
                    and statuses == plain['sent']
                    and plain['achieved_rate'] >= 0.95 * plain['rate'],
                    'value': plain['lost'],
                }
            )
        base = NODE_CPU_BASELINE_US.get(scene)
        cpu = nd.get('target_cpu_per_answer_us')
        if base is not None and cpu is not None:
            out.append(
                {
                    'target': f'{scene}, every output on: node CPU per command at most '
                    f'{TARGET_NODE_CPU_RATIO:g}x that of {NODE_CPU_BASELINE_COMMIT} (recorded: '
                    f'{base:.0f} us)',
                    'measured': f'{cpu:.0f} us per answered command, {cpu / base:.2f}x the '
                    'recorded figure (the node process, every thread, first command to last '
                    'answer; the recorded figure comes from an earlier run under its own load, '
                    'see BENCHMARKS.md)',
                    'met': cpu <= TARGET_NODE_CPU_RATIO * base,
                    'value': cpu / base,
                }
            )
        if rl.get('ok') and nd.get('p50_ms') is not None and rl.get('p50_ms') is not None:
            d = nd['p50_ms'] - rl['p50_ms']
            out.append(
                {
                    'target': f'{scene}, every output on: node p50 within '
                    f'{TARGET_LATENCY_MS} ms of the relay at {rate:g} Hz',
                    'measured': f'{d:+.3f} ms (node {nd["p50_ms"]:.3f} ms, relay '
                    f'{rl["p50_ms"]:.3f} ms; includes queueing)',
                    'met': d <= TARGET_LATENCY_MS,
                    'value': d,
                }
            )
    return out


def rate_text(v) -> str:
    return 'none of the rates tried' if v is None else f'{v:g} Hz'
