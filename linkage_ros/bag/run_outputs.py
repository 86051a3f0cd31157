"""The outputs of one bag's analysis, opened before its plans are solved so that each
trajectory or path goes to them as soon as it is answered (its rows to the trajectories' CSV,
its solved trajectory and status to a result bag): memory holds one plan's answer at a time,
whatever the number of plans in the bag. The commands' tables (CSV, Parquet, plot, the
result bag's command topics) are written from the results table once every command is
solved. Every file is written whole or not at all; :meth:`RunOutputs.abort` leaves nothing."""

from __future__ import annotations

import contextlib
import shutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NoReturn

from .bag_out import ResultBag
from .common import BagError
from .common import OutputKind as OutputKind  # re-exported: an Output's kind
from .plans import PlanRequest
from .plans_out import PlansCsvWriter
from .progress import Progress
from .reading import Commands
from .results import Results


@dataclass(frozen=True)
class Output:
    """One output file (or result bag folder) of a bag's analysis."""

    kind: OutputKind
    path: Path
    storage: str = 'mcap'  # a result bag's storage (mcap or sqlite3)


@dataclass
class RunOutputs:
    """A bag's outputs in the order written; ``plans_csvs``: where the trajectories' CSV goes
    (one beside each command CSV) when the bag has recorded plans."""

    outputs: Sequence[Output]
    mech: Any
    frame_id: str
    plans_csvs: Sequence[Path] = ()
    remap: Mapping[str, str] = field(default_factory=dict)
    #: state completion: the result bag's joint_states carry the inputs too (--publish-inputs)
    publish_inputs: bool = False
    #: on a failure, also remove the outputs finished already (a fleet's bag: all or none)
    all_or_none: bool = True
    _bags: dict[Path, ResultBag] = field(default_factory=dict)
    _plans_out: list[PlansCsvWriter] = field(default_factory=list)
    _written: list[Path] = field(default_factory=list)

    def start(self, plans: Sequence[PlanRequest]) -> Callable[[PlanRequest], None]:
        """Open what takes plans as they are answered (``plans``: the bag's, placed but not
        answered yet); returns what each answered plan is given to."""
        out = None
        try:
            for out in self.outputs:
                if out.kind is OutputKind.BAG:
                    self._bags[out.path] = ResultBag(
                        out.path, self.mech, self.frame_id, out.storage, bool(plans),
                        remap=self.remap, publish_inputs=self.publish_inputs,
                    )  # fmt: skip
            for path in self.plans_csvs if plans else ():
                out = Output(OutputKind.CSV, path)
                self._plans_out.append(PlansCsvWriter(path, self.mech))
        except BaseException as exc:
            self._failure(exc, out)
        return self.add_plan

    def _failure(self, exc: BaseException, out: Output | None) -> NoReturn:
        """Abandon the run; an OSError of ``out`` said naming it (write_failed: an error such
        as 'File too large' carries no file name)."""
        self.abort()
        if isinstance(exc, OSError) and out is not None:
            raise write_failed(out, exc) from None
        raise exc

    def add_plan(self, req: PlanRequest) -> None:
        """One answered plan to every output that takes plans."""
        out = None
        try:
            for writer in self._plans_out:
                out = Output(OutputKind.CSV, writer.path)
                writer.add(req)
            for path, bag in self._bags.items():
                out = Output(OutputKind.BAG, path)
                bag.add_plan(req)
        except BaseException as exc:
            self._failure(exc, out)

    def finish(
        self,
        data: Commands,
        res: Results,
        progress: Progress | None = None,
    ) -> list[Path]:
        """The commands' outputs, each whole, and every output closed; the paths written (the
        trajectories' CSVs last)."""
        from .csv_out import write_csv
        from .parquet_out import write_parquet
        from .plot import write_plot

        out = None
        try:
            for out in self.outputs:
                if out.kind is OutputKind.CSV:
                    write_csv(out.path, data, res, self.mech, progress)
                elif out.kind is OutputKind.PARQUET:
                    write_parquet(out.path, data, res, self.mech, progress)
                elif out.kind is OutputKind.PLOT:
                    write_plot(str(out.path), data, res, self.mech)
                else:
                    bag = self._bags[out.path]
                    bag.write_commands(data, res, progress)
                    bag.close()
                    del self._bags[out.path]
                self._written.append(out.path)
            while self._plans_out:
                writer = self._plans_out[0]
                out = Output(OutputKind.CSV, writer.path)
                writer.close()
                self._plans_out.pop(0)
                self._written.append(writer.path)
        except BaseException as exc:
            self._failure(exc, out)
        return list(self._written)

    def abort(self) -> None:
        """Nothing of this run is kept: open outputs abandoned, finished ones removed."""
        for writer in self._plans_out:
            writer.abort()
        self._plans_out.clear()
        for bag in self._bags.values():
            bag.abort()
        self._bags.clear()
        for p in self._written if self.all_or_none else ():
            with contextlib.suppress(OSError):
                if p.is_dir() and not p.is_symlink():
                    shutil.rmtree(p)
                else:
                    p.unlink()
        self._written.clear()


def write_failed(out: Output, exc: OSError) -> BagError:
    """A write error of ``out``, naming it (--plot's as the option)."""
    if out.kind is OutputKind.PLOT:
        return BagError(f'--plot {out.path}: {exc.strerror or exc}')
    return BagError(f'output {out.path}: cannot write ({exc.strerror or exc})')
