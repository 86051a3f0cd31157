"""The trajectories' CSV beside a command CSV (``out.trajectories.csv``), written as the plans
are answered: each plan's rows go to the file when it is solved, so a bag of many long
trajectories never holds more than one answer (the file appears under its name only once
whole: written to a temporary file, renamed when closed)."""

from __future__ import annotations

import contextlib
import csv
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from ..outputs import staging_name
from .plans import PlanRequest, plans_csv_path  # noqa: F401 - where the file goes


class PlansCsvWriter:
    """One row per solved point (request index, topic, request, bag time, stamp, status,
    point index, time_from_start, every published joint: mech.output_joint_names), one row per
    refused request (its reason, failed_index); :meth:`add` writes one answered plan,
    :meth:`close` puts the file in place, :meth:`abort` leaves nothing."""

    def __init__(self, path: str | os.PathLike[str], mech: Any):
        self.path = Path(path)
        self.mech = mech
        self.tmp = self.path.with_name(staging_name(self.path.name))
        self.count = 0
        self._fh: TextIO | None = open(self.tmp, 'w', newline='')  # noqa: SIM115 - closed in close()
        self._w = csv.writer(self._fh)
        head = ['request', 'topic', 'kind', 'log_ns', 'stamp_sec', 'stamp_nanosec', 'status']
        head += ['reason', 'failed_index', 'point', 'time_from_start_ns']
        head += [f'joint.{j}' for j in mech.output_joint_names]
        self._w.writerow(head)

    def add(self, req: PlanRequest) -> None:
        """The rows of one answered plan (``req.answer``), numbered in the order they come."""
        ans = req.answer
        assert ans is not None  # answered by the replay
        k, self.count = self.count, self.count + 1
        base = [k, req.topic, req.request, req.log_ns, req.stamp[0], req.stamp[1]]
        if not ans.success:
            index = '' if ans.failed_index is None else ans.failed_index
            blank = [''] * len(self.mech.output_joint_names)
            self._w.writerow(base + ['error', ans.reason, index, '', ''] + blank)
            return
        output_joints = self.mech.output_joints
        self._w.writerows(
            base
            + ['ok', '', '', i, t]
            + [repr(float(v)) for v in output_joints(r.joints, r.inputs)]
            for i, (r, t) in enumerate(zip(ans.results, req.times_ns))
        )

    def close(self) -> None:
        fh, self._fh = self._fh, None
        if fh is None:
            return
        try:
            fh.close()
            os.replace(self.tmp, self.path)
        except BaseException:
            self._remove()
            raise

    def abort(self) -> None:
        fh, self._fh = self._fh, None
        if fh is not None:
            with contextlib.suppress(OSError):
                fh.close()
        self._remove()

    def _remove(self) -> None:
        with contextlib.suppress(OSError):
            self.tmp.unlink()


def write_plans_csv(path: str | os.PathLike[str], plans: Sequence[PlanRequest], mech: Any) -> None:
    """The trajectories' CSV of plans answered already (each with its answer), whole or not at
    all."""
    out = PlansCsvWriter(path, mech)
    try:
        for req in plans:
            out.add(req)
    except BaseException:
        out.abort()
        raise
    out.close()
