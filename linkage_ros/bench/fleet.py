"""Fleet analysis (issue 28): the same bags one after the other, in two local processes and on
a two-worker Dask LocalCluster; and Parquet against CSV for one large table.

The bags are one generated MCAP bag of four-bar commands (a crank sweep with a NaN command now
and then, refused) copied under several names: every run does the same work. Each run is the
real command (``linkage bag FOLDER --out-dir ...``), timed from its start to its summary, after
an untimed warm-up run in this process (imports); the cluster is started and its workers
import the package before the clock starts (a long-lived cluster's start is not per run). The
outputs of the three runs are compared byte for byte.
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from .settings import TARGET_FLEET_SPEEDUP, Sizes, log


def _write_bag(folder: Path, n: int) -> None:
    """n crank commands 10 ms apart (one in 997 NaN): raw CDR patched from one message."""
    from rosbags.rosbag2 import Writer
    from rosbags.rosbag2.enums import StoragePlugin
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_JAZZY)
    t = ts.types
    js = 'sensor_msgs/msg/JointState'
    msg = t[js](
        header=t['std_msgs/msg/Header'](
            stamp=t['builtin_interfaces/msg/Time'](sec=0, nanosec=0), frame_id=''
        ),
        name=['crank'],
        position=np.zeros(1),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    template = bytearray(ts.serialize_cdr(msg, js))
    off = len(template) - 8 - 8  # the position, then two empty sequences' lengths
    t0 = 1_700_000_000 * 10**9
    crank = 0.3 + 0.004 * np.arange(n)
    crank[996::997] = np.nan
    with Writer(folder, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection('/cmd', js, typestore=ts)
        for i in range(n):
            stamp = t0 + i * 10**7
            raw = template[:]
            raw[4:8] = (stamp // 10**9).to_bytes(4, 'little', signed=True)
            raw[8:12] = (stamp % 10**9).to_bytes(4, 'little')
            raw[off : off + 8] = np.float64(crank[i]).tobytes()
            w.write(conn, stamp, bytes(raw))


def _warm_worker(bag: str, scene: str) -> None:
    """Analyse a small bag in this process, untimed (its imports and the scene's loading): a
    worker that has run a task before has them. Runs on each Dask worker (Client.run)."""
    from ..bag import main

    with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()):
        main([bag, '--scene', scene, '--command-topic', '/cmd', '--out-dir', tmp, '--jobs', '1'])


def _run_bag(args: list[str]) -> tuple[float, int]:
    from ..bag import main

    sink = io.StringIO()
    t0 = time.perf_counter()
    with contextlib.redirect_stdout(sink):
        code = main(args + ['--no-progress'])
    return time.perf_counter() - t0, code


def _outputs(out: Path) -> dict[str, bytes]:
    return {
        p.relative_to(out).as_posix(): p.read_bytes()
        for p in sorted(out.rglob('*.csv'))
        if p.name != 'summary.csv'
    }


def bench_fleet(sizes: Sizes) -> dict[str, Any]:
    """Serial vs --jobs 2 vs a two-worker LocalCluster, and Parquet vs CSV."""
    if not sizes.fleet_bags:
        return {'skipped': 'fleet sizes are 0'}
    from ..resources import config_dir

    scene = str(config_dir() / 'four_bar.yaml')
    out: dict[str, Any] = {'bags': sizes.fleet_bags, 'commands': sizes.fleet_commands}
    with tempfile.TemporaryDirectory(prefix='linkage-fleet-bench-') as tmp:
        root = Path(tmp)
        log(f'fleet: writing {sizes.fleet_bags} bags of {sizes.fleet_commands:,} commands')
        _write_bag(root / 'one', sizes.fleet_commands)
        for k in range(sizes.fleet_bags):
            shutil.copytree(root / 'one', root / 'fleet' / f'machine{k:02d}')
        common = [str(root / 'fleet'), '--scene', scene, '--command-topic', '/cmd']
        runs: dict[str, Any] = {}

        def measure(label: str, extra: list[str]) -> None:
            load0 = os.getloadavg()[0]
            seconds, code = _run_bag([*common, '--out-dir', str(root / label), *extra])
            runs[label] = {
                'seconds': seconds,
                'exit': code,
                'loadavg_before': round(load0, 2),
                'loadavg_after': round(os.getloadavg()[0], 2),
            }
            log(f'fleet: {label}: {seconds:.2f} s (exit {code})')

        _write_bag(root / 'warm' / 'w', 200)
        _warm_worker(str(root / 'warm'), scene)
        measure('serial', ['--jobs', '1'])
        measure('jobs2', ['--jobs', '2'])
        try:
            from dask.distributed import Client, LocalCluster

            with LocalCluster(
                n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster:
                with Client(cluster.scheduler_address) as client:
                    client.run(_warm_worker, str(root / 'warm'), scene)
                measure('cluster2', ['--scheduler', cluster.scheduler_address])
        except ImportError as exc:
            runs['cluster2'] = {'skipped': f'dask.distributed not importable ({exc})'}
        ref = _outputs(root / 'serial')
        for label, r in runs.items():
            if 'seconds' in r:
                r['speedup'] = runs['serial']['seconds'] / r['seconds']
                r['identical_to_serial'] = _outputs(root / label) == ref
        out['runs'] = runs
        out['parquet_vs_csv'] = _table_formats(root, scene, sizes.parquet_rows)
    return out


def _table_formats(root: Path, scene: str, n: int) -> dict[str, Any]:
    """Write one solved table of n rows as CSV and as Parquet: seconds and bytes."""
    from ..bag.csv_out import write_csv
    from ..bag.parquet_out import write_parquet
    from ..bag.reading import read_commands
    from ..bag.replay import ReplayEngine
    from ..core.loading import load_scene

    log(f'fleet: Parquet vs CSV, {n:,} rows')
    _write_bag(root / 'big', n)
    mech = load_scene(scene).mechanism
    data = read_commands(str(root / 'big'), ['/cmd'])
    res = ReplayEngine(mech, None, 1e-12, 50, 'continuous').solve_all(data)
    result: dict[str, Any] = {'rows': n}
    for fmt, write in (('csv', write_csv), ('parquet', write_parquet)):
        path = root / f'big.{fmt}'
        t0 = time.perf_counter()
        write(path, data, res, mech)
        result[fmt] = {'seconds': time.perf_counter() - t0, 'bytes': path.stat().st_size}
    return result


def fleet_targets(report: dict[str, Any]) -> list[dict[str, Any]]:
    fleet = report.get('fleet') or {}
    if not fleet or fleet.get('skipped'):
        why = fleet.get('skipped', 'not run')
        return [{'target': 'fleet speed-up', 'measured': f'skipped: {why}', 'met': None}]
    out = []
    runs = fleet['runs']
    for label, what in (('jobs2', '--jobs 2'), ('cluster2', 'a two-worker Dask LocalCluster')):
        r = runs.get(label, {})
        if 'speedup' not in r:
            out.append(
                {'target': f'fleet on {what}', 'measured': r.get('skipped', 'n/a'), 'met': None}
            )
            continue
        out.append(
            {
                'target': f'{fleet["bags"]} bags of {fleet["commands"]:,} commands on {what} '
                f'>= {TARGET_FLEET_SPEEDUP:g}x faster than one after the other',
                'measured': f'{r["speedup"]:.2f}x ({r["seconds"]:.2f} s vs '
                f'{runs["serial"]["seconds"]:.2f} s; load average {r["loadavg_before"]} -> '
                f'{r["loadavg_after"]}; outputs '
                + ('identical' if r['identical_to_serial'] else '**DIFFERENT**')
                + ')',
                'met': r['speedup'] >= TARGET_FLEET_SPEEDUP and r['identical_to_serial'],
                'value': r['speedup'],
            }
        )
    return out


def render_fleet(report: dict[str, Any]) -> str:
    """The markdown section of the fleet measurement."""
    fleet = report.get('fleet') or {}
    lines = ['## Fleet analysis (many bags)\n']
    if not fleet or fleet.get('skipped'):
        lines.append(f'Skipped: {fleet.get("skipped", "not run")}.\n')
        return '\n'.join(lines) + '\n'
    lines.append(
        f'`linkage bag FOLDER --out-dir DIR` on {fleet["bags"]} MCAP bags of '
        f'{fleet["commands"]:,} four-bar commands each (CSV outputs), one after the other '
        '(`--jobs 1`), in two local processes (`--jobs 2`) and on a two-worker '
        '`dask.distributed.LocalCluster` (started, and the package imported on its workers, '
        'before the clock; `--scheduler`). Wall time of the whole command after an untimed '
        'warm-up run; load average (1 min) before and after each run.\n'
    )
    lines.append('| run | seconds | speed-up | load before -> after | outputs as serial |')
    lines.append('|---|---:|---:|---|---|')
    for label, r in fleet['runs'].items():
        if 'seconds' not in r:
            lines.append(f'| {label} | - | - | - | {r.get("skipped")} |')
            continue
        lines.append(
            f'| {label} | {r["seconds"]:.2f} | {r["speedup"]:.2f}x | {r["loadavg_before"]} -> '
            f'{r["loadavg_after"]} | {"identical" if r["identical_to_serial"] else "DIFFERENT"} |'
        )
    t = fleet['parquet_vs_csv']
    c, p = t['csv'], t['parquet']
    lines.append('')
    lines.append(
        f'One solved table of {t["rows"]:,} rows: CSV {c["bytes"] / 1e6:.1f} MB in '
        f'{c["seconds"]:.2f} s, Parquet (zstd) {p["bytes"] / 1e6:.1f} MB in {p["seconds"]:.2f} s '
        f'({c["bytes"] / p["bytes"]:.1f}x smaller, {c["seconds"] / p["seconds"]:.1f}x the CSV '
        'write speed).\n'
    )
    return '\n'.join(lines) + '\n'
