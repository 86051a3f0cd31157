"""Writing the results as Parquet (pyarrow): the CSV's rows with typed columns.

Columns, in the CSV's order: ``time_ns`` (header stamp, int64 ns: sec * 10^9 + nanosec, as
the CSV's ``time``), ``receive_time_ns`` (bag time, int64 ns), ``topic`` (dictionary),
``input.<actuator>`` ..., ``joint.<joint>`` ..., (``velocity.<joint>`` ... when a command gave
velocities), ``<point>.x``, ``<point>.y`` (float64),
``residual``, ``margin`` (float64), ``branch``, ``status`` (dictionary: ``ok`` / ``error``),
``reason`` (string). Where the CSV leaves a field empty the column is null (a refused row's
joints, points and branch, an OK row's reason; an actuator a refused request did not name); a
commanded NaN stays NaN.
One row group per ``block`` rows, so a reader streams a file of any size; written to a
temporary file and renamed into place when complete (nothing half-written).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..outputs import written_whole
from .progress import Progress
from .reading import Commands
from .results import Results

#: rows per row group
ROW_GROUP = 100_000

STATUS_NAMES = ('error', 'ok')


def parquet_schema(mech: Any, rates: bool = False) -> Any:
    """The arrow schema of a bag's Parquet output (``rates``: with ``velocity.<joint>``)."""
    import pyarrow as pa

    f64 = pa.float64()
    fields = [
        pa.field('time_ns', pa.int64(), nullable=False),
        pa.field('receive_time_ns', pa.int64(), nullable=False),
        pa.field('topic', pa.dictionary(pa.int8(), pa.string()), nullable=False),
    ]
    fields += [pa.field(f'input.{a}', f64) for a in mech.output_input_names]
    fields += [pa.field(f'joint.{j}', f64) for j in mech.output_joint_names]
    if rates:
        fields += [pa.field(f'velocity.{j}', f64) for j in mech.output_joint_names]
    fields += [pa.field(f'{p}.{c}', f64) for p in mech.points for c in ('x', 'y')]
    fields += [pa.field('residual', f64), pa.field('margin', f64)]
    fields += [
        pa.field('branch', pa.dictionary(pa.int32(), pa.string())),
        pa.field('status', pa.dictionary(pa.int8(), pa.string()), nullable=False),
        pa.field('reason', pa.string()),
    ]
    return pa.schema(fields)


def _float(values: Any, null: np.ndarray | None = None) -> Any:
    """float64 column; null where ``null`` (default: where NaN)."""
    import pyarrow as pa

    v = np.ascontiguousarray(values, np.float64)
    return pa.array(v, pa.float64(), mask=np.isnan(v) if null is None else null)


def _dictionary(
    codes: np.ndarray, names: list[str], index_type: Any, empty_is_null: bool = False
) -> Any:
    """A dictionary column of ``codes`` into ``names``; ``empty_is_null``: a row whose name is
    '' is null (as the CSV leaves the field empty)."""
    import pyarrow as pa

    codes = np.asarray(codes)
    mask = None
    if empty_is_null and '' in names:
        mask = codes == names.index('')
    return pa.DictionaryArray.from_arrays(
        pa.array(codes, index_type, mask=mask), pa.array(list(names), pa.string())
    )


def write_parquet(
    path: Path | str,
    data: Commands,
    res: Results,
    mech: Any,
    progress: Progress | None = None,
    block: int = ROW_GROUP,
) -> None:
    """One row per command, in bag order, as the CSV (module docstring for the columns)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    progress = progress or Progress(False)
    n = data.n
    progress.start('parquet', n)
    rates = res.has_rates
    schema = parquet_schema(mech, rates)
    stamp = data.sec.astype(np.int64) * np.int64(10**9) + data.nanosec.astype(np.int64)
    with written_whole(path) as tmp, pq.ParquetWriter(tmp, schema, compression='zstd') as w:
        for a in range(0, n, block) if n else [0]:
            b = min(n, a + block)
            sl = slice(a, b)
            ok = res.ok[sl]
            cols = [
                pa.array(stamp[sl], pa.int64()),
                pa.array(data.log_ns[sl], pa.int64()),
                _dictionary(data.topic[sl], data.topics, pa.int8()),
            ]
            inputs = mech.output_inputs({x: res.inputs[x][sl] for x in mech.actuators})
            for nm, values in zip(mech.actuators, inputs):
                absent = ~(ok | res.input_given[nm][sl])  # a refused request without it
                cols.append(_float(np.broadcast_to(values, (b - a,)), absent))
            scene = {j: res.joints[j][sl] for j in mech.joint_names}
            given = {x: res.inputs[x][sl] for x in mech.actuators}
            cols += [_float(np.broadcast_to(v, (b - a,))) for v in mech.output_joints(scene, given)]
            if rates:
                vel = mech.output_joint_rates({j: res.joint_rates[j][sl] for j in scene})
                cols += [_float(np.broadcast_to(v, (b - a,))) for v in vel]
            for p in mech.points:
                cols += [_float(res.points[p][sl, 0]), _float(res.points[p][sl, 1])]
            cols += [_float(res.residual[sl]), _float(res.margin[sl])]
            cols.append(
                _dictionary(res.branch_code[sl], res.branch_names, pa.int32(), empty_is_null=True)
            )
            cols.append(_dictionary(ok.astype(np.int8), list(STATUS_NAMES), pa.int8()))
            reasons = [
                None if good else (res.reason[a + i] or '') for i, good in enumerate(ok.tolist())
            ]
            cols.append(pa.array(reasons, pa.string()))
            w.write_table(pa.Table.from_arrays(cols, schema=schema), row_group_size=block)
            progress.update(b)
    progress.finish()
