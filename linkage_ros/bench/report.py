"""The markdown report, its interpretation and the error-vs-time plot (prose, not library code)."""

from __future__ import annotations

from pathlib import Path

from ..outputs import written_whole
from .collect import batch_vs_scipy, find_setting
from .core_speed import core_speed_markdown
from .fleet import render_fleet
from .report_node import node_interpretation, node_markdown
from .scaling import scaling_markdown
from .settings import (
    ERROR_FLOOR,
    MARKER,
    NEWTON_TOLS,
    REF_DPS,
    TARGET_NEWTON_VS_SCIPY,
    SettingFamily,
)

# ---- markdown ----------------------------------------------------------------------------------


def _fmt_us(v) -> str:
    if v is None:
        return '-'
    return f'{v:.2f}' if v < 10 else f'{v:.1f}' if v < 100 else f'{v:.0f}'


def _fmt_err(v) -> str:
    if v is None:
        return '-'
    if v == 0:
        return '0'
    return f'{v:.1e}'


def met_text(m) -> str:
    return 'n/a' if m is None else ('**met**' if m else '**not met**')


DEFAULT_INTRO = """\
# Benchmarks

How fast and how accurate each solver setting is, measured by `linkage bench` (`make bench`).
Speed claims are ratios measured in the same run on the same machine; absolute times are noisy
on a shared 2-core machine. The text below the marker line is generated: edit this
introduction, not the tables, and re-run `make bench` to refresh them.
"""


def render_markdown(report: dict, command: str, plot_rel: str | None) -> str:
    m = report['machine']
    sz = report['sizes']
    L: list[str] = []
    w = L.append
    w('## Run\n')
    w(f'- command: `{command}`')
    other = report.get('other_cpu_cores')
    w(
        f'- date: {report["date"]}; total run time {report["seconds"]:.0f} s; other processes '
        f'used ' + ('n/a' if other is None else f'{other:.2f}') + f' of {m["nproc"]} CPU cores '
        f"on average during the run (machine busy time minus the benchmark's own processes); "
        f'load average before the run {m.get("loadavg")}'
    )
    if other is not None and other > 0.25:
        w(
            f'- **the machine was busy** (other work used {other:.2f} cores on average): absolute '
            "times are inflated and the node's loss and latency are pessimistic; the ratios "
            'measured in the same run are the numbers to use'
        )
    if report.get('code'):
        w(f'- code: commit {report["code"]}')
    simd = m.get('simd')
    w(
        f'- machine: {m["nproc"]} CPU(s) ({m["cpu"]}'
        + (
            ''
            if simd is None
            else f'; SIMD used by numpy: {", ".join(simd) or "none of AVX2/AVX-512"}'
        )
        + f'), Python {m["python"]}, numpy {m["numpy"]}, '
        f'scipy {m["scipy"]}, mpmath {m["mpmath"]}; {m["platform"]}'
    )
    w(
        f'- sizes: {sz["sweep"]} inputs per warm-started sweep x {sz["repeats"]} pass(es); '
        f'batches of {sz["batch"]:,}; throughput at n = '
        + ', '.join(f'{n:,}' for n in sz['throughput'])
        + f'; node rates {", ".join(f"{r:g}" for r in sz["node_rates"])} Hz for '
        f'{sz["node_seconds"]:g} s each'
    )
    w('')
    w('## Targets\n')
    w('| target | measured | status |')
    w('|---|---|---|')
    for t in report['targets']:
        w(f'| {t["target"]} | {t["measured"]} | {met_text(t["met"])} |')
    w('')
    w('## Speed against accuracy\n')
    w(
        'Per scene and solver setting: median time per solve of a warm-started scalar sweep '
        '(each call timed; the sweep is a closed path through the input range starting at the '
        'reference pose; the settings take turns at every input, so load drift hits all alike), '
        'median time per solve of a vectorised batch (closed forms: 20,000 inputs; Newton: '
        "the sweep's inputs as independent instances, each warm-started from its answer at the "
        'input before it, `Solver.solve_batch(start=)`), and the '
        'error of the answer against the 50-digit reference: the largest distance of any point '
        'from its reference position, divided by the mechanism length scale (max and median over '
        'the sweep). "iter" is the mean Newton iteration count (for scipy: function evaluations). '
        "scipy root runs hybr with a finite-difference Jacobian on the Newton solver's own "
        'loop-closure residual (`LoopSystem.evaluate`), warm-started from its previous solution. '
        'The "kernel" row times `LoopSystem.solve` alone (no continuation checks, no Result '
        'assembly): the like-for-like counterpart of `scipy.optimize.root`.\n'
    )
    if plot_rel:
        w(f'![error vs time per solve]({plot_rel})\n')
    w(
        '| scene | setting | us/solve (scalar) | us/solve (batch) | max error | median error | '
        'max error (batch) | fail | iter |'
    )
    w('|---|---|---:|---:|---:|---:|---:|---:|---:|')
    for r in report['settings']:
        it = '-' if r['iterations'] is None else f'{r["iterations"]:.1f}'
        berr = '-' if r['batch_err_max'] is None else _fmt_err(r['batch_err_max'])
        w(
            f'| {r["scene"]} | {r["setting"]} | {_fmt_us(r["scalar_us"])} | '
            f'{_fmt_us(r["batch_us"])} | {_fmt_err(r["err_max"])} | {_fmt_err(r["err_median"])} | '
            f'{berr} | {r["failures"]}/{r["n"]} | {it} |'
        )
    w('')
    if report['scenes']:
        refs = '; '.join(
            f'{k}: {v["reference_unknowns"]} unknowns, worst final |F| '
            f'{v["reference_residual"]:.0e}, {v["reference_seconds"]:.1f} s'
            for k, v in report['scenes'].items()
        )
        w(
            f'Reference ({REF_DPS} digits, point positions as unknowns, Newton from the dyad '
            f'plan\'s answer): {refs}. "max error (batch)" is the vectorised batch\'s error on the '
            f'same inputs (closed forms: all inputs in one batch; Newton: the instances above)'
            + ''.join(
                f'; {r["scene"]} Newton {r["tol"]:g} batch: {r["batch_failures"]} failed, '
                f'{r["batch_careful"]} of {r["n"]} rows by the careful path'
                for r in report['settings']
                if r.get('batch_careful') is not None and r['tol'] == 1e-12
            )
            + '.\n'
        )
    w('## Newton vs scipy.optimize.root\n')
    w(
        '| scene | Newton 1e-12 (Solver.solve) us | kernel (LoopSystem.solve) us | scipy root '
        '(xtol 1e-12) us | scipy / Newton | scipy / kernel | max error (Newton, scipy) | '
        'failures (Newton, scipy) |'
    )
    w('|---|---:|---:|---:|---:|---:|---|---|')
    for scene in report['scenes']:
        nw, kn, sp = (
            find_setting(report, scene, f, 1e-12)
            for f in (SettingFamily.NEWTON, SettingFamily.KERNEL, SettingFamily.SCIPY)
        )
        if not (nw and sp):
            continue
        w(
            f'| {scene} | {_fmt_us(nw["scalar_us"])} | {_fmt_us(kn["scalar_us"]) if kn else "-"} | '
            f'{_fmt_us(sp["scalar_us"])} | {sp["scalar_us"] / nw["scalar_us"]:.1f}x | '
            + (f'{sp["scalar_us"] / kn["scalar_us"]:.1f}x' if kn else '-')
            + f' | {_fmt_err(nw["err_max"])}, {_fmt_err(sp["err_max"])} | '
            f'{nw["failures"]}/{nw["n"]}, {sp["failures"]}/{sp["n"]} |'
        )
    w('')

    w('## Vectorised four-bar throughput\n')
    w(
        'Random crank angles in [-pi, pi), all three over the same inputs, timed interleaved '
        '(median of '
        + ', '.join(f'{t.get("repeats", "?")} at n = {t["n"]:,}' for t in report['throughput'])
        + ' repeats). '
        'The baseline is the textbook circle intersection in plain numpy '
        '(a = (d^2 + r1^2 - r2^2) / 2d, h = sqrt(r1^2 - a^2)) returning theta3, theta4 only; '
        '`fourbar_forward` also returns ok, the transmission angle and the closure residual '
        '(Kahan triangle height, finite outputs everywhere); `Solver.solve_batch` returns every '
        'point, link angle, joint value, the residual and the margin of each input.\n'
    )
    w(
        '| n | numpy baseline (M/s) | fourbar_forward (M/s) | Solver.solve_batch (M/s) | '
        'fourbar_forward / baseline | solve_batch / baseline | max angle difference vs baseline '
        '(rad) |'
    )
    w('|---:|---:|---:|---:|---:|---:|---|')
    for t in report['throughput']:
        rt, ra, dd = t['rate'], t['ratio_vs_baseline'], t['max_angle_diff_vs_baseline']
        w(
            f'| {t["n"]:,} | {rt["numpy baseline"] / 1e6:.2f} | '
            f'{rt["fourbar_forward"] / 1e6:.2f} | '
            f'{rt["Solver.solve_batch"] / 1e6:.2f} | {ra["fourbar_forward"]:.2f}x | '
            f'{ra["Solver.solve_batch"]:.2f}x | {dd["fourbar_forward"]:.1e}, '
            f'{dd["Solver.solve_batch"]:.1e} |'
        )
    w('')

    core = report.get('core_speed')
    if core:
        core_speed_markdown(w, core)

    w('## Cost against what the scene asks (excavator)\n')
    w(
        '`Solver(mech, outputs=[...])` prunes the dyad plan to the steps the outputs depend on. '
        'Same warm-started sweep of the three cylinder throws as above.\n'
    )
    w(
        '| outputs | plan steps | links placed | closed form us (scalar) | closed form us (batch) '
        '| Newton us (scalar) | Newton unknowns |'
    )
    w('|---|---:|---:|---:|---:|---:|---:|')
    for o in report['outputs']:
        w(
            f'| {o["label"]} | {o["plan_steps"]} | {o["links_placed"]} | '
            f'{_fmt_us(o["closed_form_scalar_us"])} | {_fmt_us(o["closed_form_batch_us"])} | '
            f'{_fmt_us(o["newton_scalar_us"])} | {o["newton_unknowns"]} |'
        )
    if report['outputs']:
        allo, one = report['outputs'][-1], report['outputs'][0]
        w(
            f'\nOne output ({one["label"].split(" ")[0]}) costs '
            f'{one["closed_form_scalar_us"] / allo["closed_form_scalar_us"]:.2f}x the scalar time '
            f'and {one["closed_form_batch_us"] / allo["closed_form_batch_us"]:.2f}x the batch time '
            f'of all outputs; Newton solves every loop whatever is asked '
            f'({one["newton_scalar_us"] / allo["newton_scalar_us"]:.2f}x).\n'
        )

    for line in scaling_markdown(report.get('scaling') or []):
        w(line)

    w(node_markdown(report['node']))
    w(render_fleet(report))
    w('## Interpretation\n')
    w(interpretation(report))
    return '\n'.join(L) + '\n'


def interpretation(report: dict) -> str:
    """Which setting to choose for what, with this run's numbers."""
    lines = []
    s = report['settings']

    def pick(family: SettingFamily, tol=None):
        return [r for r in s if r['family'] == family and (tol is None or r['tol'] == tol)]

    dy, d = pick(SettingFamily.DYAD), pick(SettingFamily.DIRECT)
    n12, n8, n4 = (
        pick(SettingFamily.NEWTON, 1e-12),
        pick(SettingFamily.NEWTON, 1e-8),
        pick(SettingFamily.NEWTON, 1e-4),
    )
    n14 = pick(SettingFamily.NEWTON, 1e-14)

    def rng(rows, key):
        vals = [r[key] for r in rows if r[key] is not None]
        if not vals:
            return '-'
        lo, hi = min(vals), max(vals)
        f = _fmt_err if 'err' in key else _fmt_us
        return f(lo) if lo == hi else f'{f(lo)}-{f(hi)}'

    speedup = [n['scalar_us'] / c['scalar_us'] for c in dy for n in n12 if n['scene'] == c['scene']]
    lines.append(
        f'- **Closed form first.** Wherever the dyad plan exists it is the scalar path to use: '
        f'{rng(dy, "scalar_us")} us per solve, '
        + (
            f'{min(speedup):.1f}-{max(speedup):.1f}x cheaper than Newton at 1e-12, '
            if speedup
            else ''
        )
        + f'exact to rounding (max error {rng(dy, "err_max")} of the length scale) and pruned to '
        f'the outputs asked for; batched it costs {rng(dy, "batch_us")} us per input. The direct '
        f'`core.fourbar` functions are for large vectorised four-bar / slider-crank sweeps '
        f'({rng(d, "batch_us")} us per input batched), not single calls '
        f'({rng(d, "scalar_us")} us: numpy overhead on 0-d arrays).'
    )
    lines.append(
        f'- **Newton tolerance is the speed/accuracy knob only where closed form is absent.** '
        f'Warm-started Newton costs {rng(n12, "scalar_us")} us at 1e-12 (error '
        f'{rng(n12, "err_max")}) vs {rng(n4, "scalar_us")} us at 1e-4 (error '
        f'{rng(n4, "err_max")}): a loose tolerance saves little time because quadratic '
        f'convergence makes the last digits nearly free, so keep 1e-12 (the default); 1e-8 '
        f'gives {rng(n8, "err_max")}. 1e-14 is at the rounding floor ({rng(n14, "scalar_us")} '
        f'us, {sum(r["failures"] for r in n14)} failure(s) in the sweeps).'
    )
    sp = pick(SettingFamily.SCIPY, 1e-12)
    pairs = [(a, b) for a in n12 for b in sp if a['scene'] == b['scene']]
    if pairs:
        lo = min(pairs, key=lambda p: p[1]['scalar_us'] / p[0]['scalar_us'])
        hi = max(pairs, key=lambda p: p[1]['scalar_us'] / p[0]['scalar_us'])
        kern = {r['scene']: r for r in pick(SettingFamily.KERNEL, 1e-12)}
        kr = [
            b['scalar_us'] / kern[a['scene']]['scalar_us']
            for a, b in pairs
            if a['scene'] in kern and kern[a['scene']]['scalar_us']
        ]
        lines.append(
            f'- **Against scipy.optimize.root** (same residual, warm-started) the Newton solve at '
            f'1e-12 is {lo[1]["scalar_us"] / lo[0]["scalar_us"]:.1f}x ({lo[0]["scene"]}) to '
            f'{hi[1]["scalar_us"] / hi[0]["scalar_us"]:.1f}x ({hi[0]["scene"]}) as fast (>1: '
            'faster)'
            + (f', the kernel alone {min(kr):.1f}-{max(kr):.1f}x' if kr else '')
            + '. A warm Newton solve predicts the answer from the last two (a secant step in the '
            'inputs through the previous Jacobian factorisations), then takes '
            + ', '.join(f'{a["scene"]} {a["iterations"]:.1f}' for a, _ in pairs)
            + ' Newton steps on average, each with one residual + analytic Jacobian evaluation '
            'and one LU factorisation (which also gives the det J sign for branch tracking). '
            'hybr spends n + 1 evaluations of the same residual on a finite-difference Jacobian '
            'and then iterates (evaluations per solve: '
            + ', '.join(f'{b["scene"]} {b["iterations"]:.0f}' for _, b in pairs)
            + '). Making the residual cheaper speeds both alike, so the ratio is set by these '
            'counts: 20x would need a whole Newton solve, branch checks included, to cost less '
            "than one twentieth of scipy's evaluations ("
            + ', '.join(
                f'{b["scene"]} {b["iterations"] / TARGET_NEWTON_VS_SCIPY:.1f}' for _, b in pairs
            )
            + ' residual evaluations), while it needs at least two (one to check the prediction, '
            'one to confirm the step). That is out of reach on the same residual wherever '
            'scipy needs fewer than 40 evaluations. What the Newton path adds is the branch '
            'and singularity checks, '
            'continuation and a full Result, at a speed comparable to scipy on small systems '
            'and faster on large ones. Vectorised over many instances '
            '(`Solver.solve_batch(start=)`: one numpy Newton for all rows, the same branch '
            'proofs per row) the per-solve cost drops to '
            + ', '.join(
                f'{a["scene"]} {a["batch_us"]:.0f} us ({batch_vs_scipy(a, b)[0]:.1f}x scipy)'
                for a, b in pairs
                if a.get('batch_us')
            )
            + ': there the work per solve is a few LAPACK calls on small matrices, not Python.'
        )
        bad = [b for _, b in pairs if b['failures'] or (b['err_max'] or 0) > 1e-6]
        if bad:
            lines.append(
                '- **scipy is not robust on this problem**: '
                + '; '.join(
                    f'{b["scene"]}: {b["failures"]} of {b["n"]} solves failed, max error '
                    f'{_fmt_err(b["err_max"])}'
                    for b in bad
                )
                + ". MINPACK's finite-difference step is relative to |x_j|, so a variable that "
                'is ~0 (a link angle near its reference pose, ~1e-16 after a converged solve) gets '
                'a ~1e-24 step and a Jacobian column of rounding noise; warm-started hybr then '
                'stalls ("not making good progress") and when it recovers it can land in another '
                'assembly mode (an error of order the length scale, reported as success). The '
                'analytic Jacobian of the Newton path has no such failure mode.'
            )
    outs = report.get('outputs') or []
    if outs:
        one, allo = outs[0], outs[-1]
        lines.append(
            f'- **Ask only for what you need**: on the excavator a solver for one output '
            f'({one["label"].split(" ")[0]}) runs {one["plan_steps"]} of {allo["plan_steps"]} '
            f'plan steps and costs '
            f'{one["closed_form_scalar_us"] / allo["closed_form_scalar_us"]:.2f}'
            f'x (scalar) and {one["closed_form_batch_us"] / allo["closed_form_batch_us"]:.2f}x '
            '(batch) of the all-outputs solve; Newton is not pruned (every loop is solved '
            'whatever is asked), so pruning is one more reason to prefer the closed form.'
        )
    lines.extend(node_interpretation(report.get('node') or {}))
    return '\n'.join(lines) + '\n'


# ---- plot --------------------------------------------------------------------------------------


def save_plot(report: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    scenes = list(report['scenes'])
    colors = dict(
        zip(scenes, ['tab:blue', 'tab:orange', 'tab:green', 'tab:red', 'tab:purple', 'tab:brown'])
    )
    markers = {SettingFamily.DIRECT: 's', SettingFamily.DYAD: 'D', SettingFamily.SCIPY: 'X'}
    nmark = dict(zip(NEWTON_TOLS, ['v', '^', 'o', 'P']))
    fig, ax = plt.subplots(figsize=(8.5, 5.6))
    labels_used = {}
    for r in report['settings']:
        if r['err_max'] is None or r['scalar_us'] is None:
            continue
        fam = SettingFamily(r['family'])
        mk = nmark.get(r['tol'], 'o') if fam is SettingFamily.NEWTON else markers.get(fam, 'o')
        if fam is SettingFamily.SCIPY:
            mk = 'X' if r['tol'] == 1e-12 else 'x'
        lab = r['setting'] if fam is not SettingFamily.DIRECT else 'direct closed form'
        y = max(r['err_max'], ERROR_FLOOR)
        ax.scatter(
            r['scalar_us'],
            y,
            marker=mk,
            s=55,
            color=colors[r['scene']],
            edgecolors='k' if mk not in ('x',) else None,
            linewidths=0.5,
            zorder=3,
        )
        labels_used[lab] = mk
        if r['batch_us'] is not None and r['batch_err_max'] is not None:
            ax.scatter(
                r['batch_us'],
                max(r['batch_err_max'], ERROR_FLOOR),
                marker=mk,
                s=55,
                facecolors='none',
                edgecolors=colors[r['scene']],
                linewidths=1.2,
                zorder=3,
            )
    ax.set_xscale('log')
    ax.set_yscale('log')
    if any(r['err_max'] is not None and r['err_max'] < ERROR_FLOOR for r in report['settings']):
        ax.axhline(ERROR_FLOOR, color='0.7', lw=0.8, ls=':')
        ax.text(
            0.02,
            ERROR_FLOOR * 1.6,
            f'error < {ERROR_FLOOR:g} (e.g. exactly 0) drawn here',
            transform=ax.get_yaxis_transform(),
            fontsize=7,
            color='0.4',
        )
    ax.set_xlabel('median time per solve (us); hollow = per input of a vectorised batch')
    ax.set_ylabel('max point error / length scale (vs 50-digit reference)')
    ax.set_title('Solver settings: error vs time per solve')
    ax.grid(True, which='major', alpha=0.3)
    h1 = [Line2D([], [], ls='', marker='o', color=colors[s], label=s) for s in scenes]
    h2 = [
        Line2D([], [], ls='', marker=mk, color='0.3', label=lab) for lab, mk in labels_used.items()
    ]
    leg = ax.legend(
        handles=h1,
        loc='upper left',
        fontsize=7,
        title='scene',
        title_fontsize=7,
        bbox_to_anchor=(1.01, 1.0),
    )
    ax.add_artist(leg)
    ax.legend(
        handles=h2,
        loc='lower left',
        fontsize=7,
        title='setting',
        title_fontsize=7,
        bbox_to_anchor=(1.01, 0.0),
    )
    fig.tight_layout()
    with written_whole(path) as tmp:
        fig.savefig(tmp, dpi=120, format=path.suffix[1:] or 'png')
    plt.close(fig)


def write_report(path: Path, body: str) -> None:
    """Replace everything below MARKER and keep the introduction above it. A file without the
    marker is all introduction (the marker and the report are appended); a missing file gets
    a default introduction."""
    intro = DEFAULT_INTRO
    if path.exists():
        text = path.read_text(encoding='utf-8')
        intro = text.split(MARKER, 1)[0].rstrip('\n') + '\n'
    path.parent.mkdir(parents=True, exist_ok=True)
    with written_whole(path) as tmp:
        tmp.write_text(f'{intro}\n{MARKER}\n\n{body}', encoding='utf-8')
