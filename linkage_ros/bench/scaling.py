"""Big scenes: what `linkage range` and `linkage check` cost per actuator as a scene grows.

The scene is N independent crank-rocker four-bars (config/four_bar.yaml's lengths, each drawn
at a different crank angle) on one ground, written in the general form to a temporary YAML
file. Each size is timed from loading that file to the finished report, in this process
(the CLI's start-up is the same for every size and is left out): `linkage range` is
``Scene.from_yaml`` + ``motion.actuator_ranges``; `linkage check` is ``Scene.from_yaml`` +
``check_report``; a small scene is timed several times and its best time kept. The target: the
time per actuator stays within 2x from the smallest to the largest scene, and the largest (300
actuators) takes under 10 s.
"""

from __future__ import annotations

import math
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from .settings import log

#: config/four_bar.yaml: ground, crank, coupler, rocker (m)
LENGTHS = (0.30, 0.10, 0.25, 0.20)
#: the largest scene is held to this wall time (s), every size to this spread of s per actuator
TARGET_LARGEST_S = 10.0
TARGET_PER_ACTUATOR_SPREAD = 2.0
#: a small scene is timed repeatedly (best of round(this / N)): a fraction of a second is at the
#: mercy of a shared machine's load, and one slow run would read as a spread
_REPEAT_ACTUATORS = 60


def four_bars_scene(n: int) -> dict[str, Any]:
    """A general-form scene of ``n`` independent four-bars on one ground, 0.5 m apart along y,
    four-bar k drawn with its crank at 0.3 + 5.9 k / n rad, the rocker on the open side."""
    ground_len, crank, coupler, rocker = LENGTHS
    points: dict[str, list[float]] = {}
    links: dict[str, list[str]] = {'ground': []}
    actuators: dict[str, dict[str, str]] = {}
    for k in range(n):
        y0 = 0.5 * k
        theta = 0.3 + 5.9 * k / n
        ax, ay = crank * math.cos(theta), y0 + crank * math.sin(theta)
        dx, dy = ground_len - ax, y0 - ay  # A -> O4
        d = math.hypot(dx, dy)
        along = (coupler * coupler - rocker * rocker + d * d) / (2 * d)
        off = math.sqrt(coupler * coupler - along * along)
        bx, by = ax + (along * dx - off * dy) / d, ay + (along * dy + off * dx) / d
        o2, o4, a, b = (f'{p}_{k}' for p in ('O2', 'O4', 'A', 'B'))
        points.update({o2: [0.0, y0], o4: [ground_len, y0], a: [ax, ay], b: [bx, by]})
        links['ground'] += [o2, o4]
        links[f'crank_{k}'] = [o2, a]
        links[f'coupler_{k}'] = [a, b]
        links[f'rocker_{k}'] = [o4, b]
        actuators[f'crank_{k}'] = {'type': 'angle', 'link': f'crank_{k}', 'pivot': o2, 'toward': a}
    return {
        'name': f'four_bars_{n}',
        'frame_id': 'base_link',
        'points': points,
        'ground': 'ground',
        'links': links,
        'actuators': actuators,
    }


def _time_range(path: Path) -> float:
    from ..core import motion
    from ..core.model import Scene

    t0 = time.perf_counter()
    motion.actuator_ranges(Scene.from_yaml(path).mechanism)
    return time.perf_counter() - t0


def _time_check(path: Path) -> float:
    from ..cli.check import check_report
    from ..core.model import Scene

    t0 = time.perf_counter()
    check_report(Scene.from_yaml(path).mechanism, str(path), None)
    return time.perf_counter() - t0


def bench_scaling(sizes: Sequence[int]) -> list[dict[str, Any]]:
    """[{'actuators', 'scene_kb', 'range_s', 'check_s'}] for each number of four-bars."""
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, n in enumerate(sorted(sizes)):
            path = Path(tmp) / f'four_bars_{n}.yaml'
            path.write_text(yaml.safe_dump(four_bars_scene(n)), encoding='utf-8')
            if i == 0:  # imports and first-call caches out of the first size's time
                _time_range(path)
                _time_check(path)
            repeats = max(1, round(_REPEAT_ACTUATORS / n))
            log(f'scaling: {n} independent four-bars (range, check; best of {repeats})')
            out.append(
                {
                    'actuators': n,
                    'scene_kb': path.stat().st_size / 1024,
                    'repeats': repeats,
                    'range_s': min(_time_range(path) for _ in range(repeats)),
                    'check_s': min(_time_check(path) for _ in range(repeats)),
                }
            )
    return out


def scaling_targets(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """The targets of :func:`bench_scaling`'s rows (met None where a size was not measured)."""
    if not rows:
        return []
    out = []
    largest = max(rows, key=lambda r: r['actuators'])
    for key, what in (('range_s', 'linkage range'), ('check_s', 'linkage check')):
        per = [r[key] / r['actuators'] for r in rows]
        spread = max(per) / min(per)
        out.append(
            {
                'target': f'{what}: time per actuator within {TARGET_PER_ACTUATOR_SPREAD:g}x from '
                f'{rows[0]["actuators"]} to {largest["actuators"]} independent four-bars',
                'measured': f'{spread:.2f}x ('
                + ', '.join(f'{r["actuators"]}: {1e3 * p:.1f} ms' for r, p in zip(rows, per))
                + ' per actuator)',
                'met': spread <= TARGET_PER_ACTUATOR_SPREAD,
                'value': spread,
            }
        )
        out.append(
            {
                'target': f'{what}: 300 actuators in under {TARGET_LARGEST_S:g} s',
                'measured': f'{largest[key]:.2f} s for {largest["actuators"]} actuators'
                if largest['actuators'] >= 300
                else f'not measured (largest size {largest["actuators"]}: {largest[key]:.2f} s)',
                'met': largest[key] < TARGET_LARGEST_S if largest['actuators'] >= 300 else None,
                'value': largest[key],
            }
        )
    return out


def scaling_markdown(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The report's section on big scenes (none when the case was not run)."""
    if not rows:
        return []
    lines = [
        '## Big scenes (independent four-bars on one ground)\n',
        "Load the scene file and run `linkage range` (every actuator's range and toggles) or "
        '`linkage check` (the whole report) in-process, best of round(60 / N) runs; each '
        'actuator is scanned on the independent part of the scene it moves.\n',
        '| actuators | scene KB | range s | range ms / actuator | check s | check ms / actuator |',
        '|---:|---:|---:|---:|---:|---:|',
    ]
    for r in rows:
        n = r['actuators']
        lines.append(
            f'| {n} | {r["scene_kb"]:.0f} | {r["range_s"]:.2f} | {1e3 * r["range_s"] / n:.1f} | '
            f'{r["check_s"]:.2f} | {1e3 * r["check_s"] / n:.1f} |'
        )
    lines.append('')
    return lines
