"""Plans off the command path: a worker thread solves trajectories and paths (ROS-free).

A plan (``~/trajectory``, ``~/target_path/<point>``) of 10^4 points takes seconds to solve;
commands are the control path and must keep their latency meanwhile. So the node hands each
plan, still serialised, to a :class:`PlanWorker`:

* a bounded queue (:data:`PLAN_QUEUE` waiting, one being solved): a plan offered while it is
  full is dropped for load, and the node's status says so;
* the worker reads the bytes (plan_cdr.py), solves the plan on an engine of its own started
  from the command engine's last good state as it was when the plan arrived (the command
  engine is never touched by the worker: a plan cannot interleave with commands), writes the
  solved trajectory as bytes, and hands the finished job back (``on_done``, called from the
  worker thread: the node triggers a guard condition and publishes on its executor thread);
* it is Python, so it holds the interpreter lock while it runs; the lock is handed to the
  command thread within :data:`SWITCH_INTERVAL_S` of its asking (sys.setswitchinterval:
  CPython's default is 5 ms), which bounds what a running plan adds to a command's latency.
"""

from __future__ import annotations

import queue
import sys
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field

from .core.errors import CommandError
from .core.solver import Result
from .engine import Engine
from .plan_cdr import CdrError, Stamp, joint_trajectory_bytes, read_joint_trajectory, read_path
from .trajectory import TrajectoryAnswer, answer_path_msg, answer_trajectory_msg

#: plans waiting beside the one being solved; one more is dropped for load
PLAN_QUEUE = 2
#: the longest the worker keeps the interpreter lock from a command thread that asks for it (s)
SWITCH_INTERVAL_S = 0.0005


@dataclass
class PlanJob:
    """One plan request, its bytes still serialised, and (once solved) its answer."""

    request: str  # 'trajectory' or 'target_path/<point>' (the status's request key)
    raw: bytes
    #: the engine serving commands when the plan arrived (its mechanism, settings and state)
    engine: Engine
    #: that engine's last good state when the plan arrived: where the plan starts
    start: Result | None
    frame_id: str  # the node's frame
    prefix: str  # the node's joint-name prefix (the solved trajectory's joint names)
    point: str | None = None  # a path's point; None for a trajectory
    #: the stamp the answers carry (the request's, or the node clock's now for a zero one)
    stamp: Stamp = Stamp(0, 0)
    answer: TrajectoryAnswer | None = None
    solved: bytes | None = None  # ~/solved_trajectory, serialised, on success
    times_ns: list[int] = field(default_factory=list)


class PlanWorker:
    """A thread and a bounded queue of :class:`PlanJob` (see the module docstring)."""

    def __init__(self, on_done: Callable[[PlanJob], None], depth: int = PLAN_QUEUE):
        self._on_done = on_done
        self._jobs: queue.Queue[PlanJob | None] = queue.Queue(maxsize=depth)
        self._thread: threading.Thread | None = None
        #: the command engine the worker's own engine copies, and that copy
        self._for: Engine | None = None
        self._engine: Engine | None = None
        self.busy = False  # a plan is being solved

    @property
    def waiting(self) -> int:
        return self._jobs.qsize()

    def offer(self, job: PlanJob) -> bool:
        """Queue ``job``; False, queueing nothing, when the queue is full (dropped for load)."""
        if self._thread is None:
            sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL_S))
            self._thread = threading.Thread(target=self._run, name='linkage_plans', daemon=True)
            self._thread.start()
        try:
            self._jobs.put_nowait(job)
        except queue.Full:
            return False
        return True

    def stop(self, timeout: float = 2.0) -> None:
        """End the thread after the plan it solves (those waiting are not solved)."""
        if self._thread is None:
            return
        while True:
            try:
                self._jobs.get_nowait()
            except queue.Empty:
                break
        try:
            self._jobs.put(None, timeout=timeout)
        except queue.Full:
            return
        self._thread.join(timeout)
        self._thread = None

    def _run(self) -> None:
        while True:
            job = self._jobs.get()
            if job is None:
                return
            self.busy = True
            try:
                solve_job(job, self._engine_for(job))
            except Exception as exc:  # a bug must not end the worker: the job says so
                job.answer = TrajectoryAnswer(
                    False, f'internal error: {exc!r}\n' + traceback.format_exc()
                )
            finally:
                self.busy = False
            self._on_done(job)

    def _engine_for(self, job: PlanJob) -> Engine:
        """The worker's engine for ``job``'s mechanism (made again when the node's engine is
        replaced), at the job's start state."""
        if self._engine is None or self._for is not job.engine:
            self._engine = Engine(job.engine.mech, job.engine.settings)
            self._for = job.engine
        engine = self._engine
        if job.start is not None and engine.forward.adopt(job.start):
            engine.record(engine.forward, job.start)
        return engine


def solve_job(job: PlanJob, engine: Engine) -> None:
    """Read, solve and write one plan on ``engine`` (fills the job's answer, times and, on
    success, its solved trajectory)."""
    try:
        msg = read_joint_trajectory(job.raw) if job.point is None else read_path(job.raw)
    except CdrError as exc:
        kind = 'JointTrajectory' if job.point is None else 'Path'
        job.answer = TrajectoryAnswer(False, f'not a {kind}: {exc}')
        return
    try:
        if job.point is None:
            answer, times = answer_trajectory_msg(engine, msg, job.frame_id)
        else:
            answer, times = answer_path_msg(engine, job.point, msg, job.frame_id)
    except CommandError as exc:
        answer, times = TrajectoryAnswer(False, str(exc)), []
    job.answer, job.times_ns = answer, times
    if answer.success:
        mech = engine.mech
        job.solved = joint_trajectory_bytes(
            job.stamp,
            job.frame_id,
            [job.prefix + j for j in mech.output_joint_names],
            answer.rows(mech, times),
        )
