"""Plans off the command path: a worker process solves trajectories and paths (ROS-free).

A plan (``~/trajectory``, ``~/target_path/<point>``) of 10^4 points takes seconds to solve;
commands are the control path and must keep their latency meanwhile. So the node hands each
plan, still serialised, to a :class:`PlanWorker`:

* a bounded queue (:data:`PLAN_QUEUE` waiting, one being solved): a plan offered while it is
  full is dropped for load, and the node's status says so;
* a process of its own (not a thread: a Python thread holds the interpreter lock the command
  thread needs, and measured beside a 10 Hz flood of 10^4-point trajectories the node lost
  most of its 500 Hz commands), started with the node (its interpreter start-up and imports,
  ~1 s of CPU, are not paid beside the first plan's commands) and scheduled only on CPU time
  nothing else wants (:func:`lower_priority`: SCHED_IDLE), so that the command thread, and
  whatever the node's clients run on the same cores, are served first;
* paced (:class:`Pacer`) while the node is answering commands (one came in the last
  :data:`COMMANDS_RECENT_S`, :class:`CommandClock`): after a first :data:`PLAN_BURST_S` it runs
  at most :data:`PLAN_SHARE` of the time, in slices of :data:`PLAN_SLICE_S`, and sleeps the rest
  ("work sliced between commands"); with no commands coming it runs at full speed. SCHED_IDLE
  alone did not keep a busy worker from the commands: beside a 10 Hz flood of 10^4-point
  trajectories on the shared 2-core host, the same node with its worker stopped (SIGSTOP)
  answered its 500 Hz commands as without a flood, and with the worker solving did worse in 5
  of 5 paired runs (p99 188-1132 ms against 8.7-23.9 ms at load 4-5). Whatever the way (the
  worker's CPU time, or the node's threads that move its jobs and answers), it grows with how
  much the worker runs; pacing bounds that (BENCHMARKS.md: the measured effect);
* it reads the bytes (plan_cdr.py), solves the plan on an engine of its own (built when the
  node serves the mechanism: :class:`PlanMechanism`) started from the command engine's last
  good state as it was when the plan arrived (the command engine is
  never touched: a plan cannot interleave with commands), and sends back the status values
  and the solved trajectory as bytes (:class:`PlanDone`);
* those answers are read from the pipe by a thread of the node's (:func:`read_answers`), never
  by the command thread: an answer is MBs, written in pipe-sized pieces by a process that runs
  only when a core is idle, and reading it on the command thread would wait on that process.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import gc
import math
import multiprocessing
import os
import queue
import signal
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .core.errors import CommandError
from .core.model import Mechanism
from .core.solver import Result
from .engine import Engine, EngineSettings
from .plan_cdr import CdrError, Stamp, joint_trajectory_bytes, read_joint_trajectory, read_path
from .trajectory import (
    TrajectoryAnswer,
    answer_path_msg,
    answer_trajectory_msg,
    trajectory_status_values,
)

#: Ctrl-C signals the node's whole process group: the worker ignores it (the node stops it).
#: Not SIGTERM: multiprocessing ends a daemon child at the node's exit by SIGTERM and then
#: waits for it without a timeout (a worker that ignored it would hang an exit that did not
#: stop it first); SIGTERM's default action ends the worker without a traceback
_GROUP_SIGNALS = {signal.SIGINT}
#: plans waiting beside the one being solved; one more is dropped for load
PLAN_QUEUE = 2
#: the worker's CPU priority where SCHED_IDLE is not available (nice)
PLAN_NICE = 19
#: how often the worker looks whether the node is still there (s)
PARENT_CHECK_S = 1.0
#: how long a stopping node waits for the worker to end before it is terminated (s)
STOP_WAIT_S = 0.1
#: the share of the time the worker may run over a long plan (the rest it sleeps)
PLAN_SHARE = 0.2
#: the budget a plan may spend unpaced after the worker was idle (s): a short plan is not
#: slowed (running spends 1 - PLAN_SHARE of its time: the burst lasts 0.125 s of running)
PLAN_BURST_S = 0.1
#: the budget a paced worker runs on between two pauses (s: 6.25 ms of running, then a
#: 25 ms pause)
PLAN_SLICE_S = 0.005
#: the worker is paced only while the node answered a request (a command, a target) this
#: recently (s): with no commands to protect, a plan runs at full speed
COMMANDS_RECENT_S = 0.2


class CommandClock:
    """When the node last answered a request (time.monotonic, s; the clock is system-wide),
    in memory shared with the plan worker: the worker paces itself only while commands come
    (:class:`Pacer`). Written by the node's executor thread, read by the worker; a torn read
    is impossible for an aligned double on the platforms ROS supports, and a stale one only
    paces a little more or less."""

    def __init__(self) -> None:
        ctx = multiprocessing.get_context('spawn')
        self.shared = ctx.RawValue('d', -math.inf)  # inherited by the worker at its start

    def stamp(self) -> None:
        """A request is being answered now."""
        self.shared.value = time.monotonic()

    def last(self) -> float:
        """When the last request was answered (-inf: none yet)."""
        return float(self.shared.value)


@dataclass(frozen=True)
class PlanJob:
    """One plan request, its bytes still serialised."""

    request: str  # 'trajectory' or 'target_path/<point>' (the status's request key)
    raw: bytes
    generation: int  # which mechanism the node served when the plan arrived
    start: Result | None  # that mechanism's last good state then: where the plan starts
    frame_id: str  # the node's frame
    prefix: str  # the node's joint-name prefix (the solved trajectory's joint names)
    point: str | None  # a path's point; None for a trajectory
    stamp: Stamp  # the stamp the answers carry


@dataclass(frozen=True)
class PlanMechanism:
    """A mechanism the node now serves, sent to the worker as soon as the node serves it (and
    again to a worker started after one died): the worker builds its engine then (half a
    second of CPU for the four-bar), not when the first plan arrives beside a stream of
    commands. The plans after it are solved on that engine."""

    generation: int
    mechanism: Mechanism
    settings: EngineSettings


@dataclass(frozen=True)
class PlanDone:
    """A solved (or refused) plan: its one status and, on success, ~/solved_trajectory."""

    request: str
    generation: int
    stamp: Stamp
    ok: bool
    message: str
    values: dict[str, str]
    solved: bytes | None  # serialised trajectory_msgs/JointTrajectory
    error: str = ''  # an internal error's traceback, for the node's log


class WorkerGone:
    """What :func:`read_answers` hands on after the worker's last answer: it has exited."""


class PlanWorker:
    """A worker process and a bounded queue of :class:`PlanJob` (see the module docstring).
    Used from one thread (the node's executor)."""

    def __init__(self, depth: int = PLAN_QUEUE, commands: CommandClock | None = None):
        self.depth = depth
        #: when the node last answered a request, shared with every worker it starts
        self.commands = commands if commands is not None else CommandClock()
        self.pending = 0  # offered and not collected: waiting, being solved or done
        #: those jobs in order, without their bytes (the worker answers in order)
        self._offered: collections.deque[PlanJob] = collections.deque()
        self._proc: Any = None
        self._jobs: Any = None
        #: the answers read_answers has read (a PlanDone each, then WorkerGone)
        self._answers: queue.SimpleQueue[PlanDone | WorkerGone] = queue.SimpleQueue()
        self._generation_sent: int | None = None
        self._reader: threading.Thread | None = None
        #: answers owed from a worker that exited, handed on by the next :meth:`collect`
        self._owed: list[PlanDone] = []

    @property
    def pid(self) -> int | None:
        """The worker process's pid; None when none is running (before start, after stop)."""
        return None if self._proc is None else int(self._proc.pid)

    def start(self) -> None:
        """Start the worker process now, if it is not running (the node does at start-up;
        :meth:`offer` does for a plan after a worker that died)."""
        if self._proc is not None:
            return
        ctx = multiprocessing.get_context('spawn')  # a fork of a process with DDS threads hangs
        self._jobs = ctx.Queue()  # its feeder thread writes the plans: never the command thread
        answers_in, answers_out = ctx.Pipe(duplex=False)
        self._answers = queue.SimpleQueue()
        self._proc = ctx.Process(
            target=serve_plans,
            args=(self._jobs, answers_out, os.getpid(), self.commands),
            name='linkage_plans',
            daemon=True,
        )
        # born with SIGINT blocked (the mask survives the spawn's exec): Ctrl-C to the node's
        # process group arriving while the worker imports raised KeyboardInterrupt there, a
        # traceback on the node's terminal; the worker ignores it from its first instruction
        # and the node stops it (stop)
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, _GROUP_SIGNALS)
        try:
            self._proc.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        # its priority lowered from its first instruction: its start-up (importing numpy and
        # the engine, ~1 s of CPU) must not compete with commands either
        lower_priority(self._proc.pid)
        answers_out.close()  # the worker holds the only write end: its exit ends the reader
        self._reader = threading.Thread(
            target=read_answers,
            args=(answers_in, self._answers),
            name='linkage_plan_answers',
            daemon=True,
        )
        self._reader.start()

    def prepare(self, generation: int, engine: Engine) -> None:
        """Send ``engine``'s mechanism (generation ``generation``) to the worker now, starting
        it if it is not running: it builds its engine while no plan waits."""
        self.start()
        if self._generation_sent != generation:
            self._jobs.put(PlanMechanism(generation, engine.mech, engine.settings))
            self._generation_sent = generation

    def offer(self, job: PlanJob, engine: Engine) -> bool:
        """Queue ``job`` (of ``engine``'s mechanism); False, queueing nothing, when the queue
        is full (dropped for load)."""
        if self._proc is not None and not self._proc.is_alive():
            # it exited (idle, or holding plans): what it held is answered first, by the next
            # collect, and a new worker takes this plan (its queue is not full: it is gone)
            if self._reader is not None:
                self._reader.join(STOP_WAIT_S)  # it ends at the dead worker's last answer
            self._drain(self._owed)
            self._owed += self._bury()
        if self.pending > self.depth:
            return False
        self.prepare(job.generation, engine)  # a new worker has not had the mechanism yet
        self._jobs.put(job)
        self._offered.append(dataclasses.replace(job, raw=b'', start=None))
        self.pending += 1
        return True

    def collect(self) -> list[PlanDone]:
        """The plans finished since the last call (never waits: the answers were read from the
        pipe by another thread). If the worker process died, the plans it had are answered as
        internal errors and the next plan starts a new one."""
        out, self._owed = self._owed, []
        if self._drain(out) and self._proc is not None:
            out += self._bury()
        return out

    def _drain(self, out: list[PlanDone]) -> bool:
        """Move the answers read so far into ``out`` (their plans no longer pending); True
        when the worker's last answer was among them (it has exited)."""
        while True:
            try:
                answer = self._answers.get_nowait()
            except queue.Empty:
                return False
            if isinstance(answer, WorkerGone):
                return True
            out.append(answer)
            self._offered.popleft()
            self.pending -= 1

    def _bury(self) -> list[PlanDone]:
        """The plans an exited worker still held, each answered as an internal error; the
        worker stopped (the next plan starts a new one)."""
        if self._proc is None:
            return []
        self._proc.join(STOP_WAIT_S)
        why = (
            f'internal error: the plan worker exited (exit code {self._proc.exitcode}); '
            'the next plan starts a new one'
        )
        lost = [
            PlanDone(j.request, j.generation, j.stamp, False, why, {'request': j.request}, None)
            for j in self._offered
        ]
        self.stop()
        return lost

    def stop(self) -> None:
        """End the worker process (the plan it solves is not answered): asked to, and
        terminated if it has not ended within STOP_WAIT_S (it may be in a plan of seconds)."""
        if self._proc is None:
            return
        with contextlib.suppress(Exception):
            self._jobs.put(None)
        self._proc.join(STOP_WAIT_S)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(2.0)
        self._jobs.close()
        self._jobs.cancel_join_thread()
        self._proc = self._jobs = self._reader = None
        self._answers = queue.SimpleQueue()  # the old reader's, if any is left, go nowhere
        self.pending = 0
        self._offered.clear()
        self._generation_sent = None  # a new worker needs the mechanism again


class Pacer:
    """Called between the steps of a plan (a point read, solved or written): sleeps so that,
    after a burst of ``burst_s`` (refilled while the worker waits for plans), the worker runs
    at most ``share`` of the wall-clock time, in slices of ``slice_s``. Time is wall-clock, not
    CPU: a worker that waits for a core is taking one from the run queue all the same.
    ``clock`` and ``sleep`` are time.monotonic and time.sleep (seconds). With ``commands_at``
    (when the node last answered a request, on the same clock) it paces only while one came
    within :data:`COMMANDS_RECENT_S`."""

    def __init__(
        self,
        share: float = PLAN_SHARE,
        burst_s: float = PLAN_BURST_S,
        slice_s: float = PLAN_SLICE_S,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        commands_at: Callable[[], float] | None = None,
    ):
        if not 0.0 < share <= 1.0:
            raise ValueError(f'share must be in (0, 1], got {share}')
        # the budget holds at least one slice: a burst shorter than a slice would pause the
        # worker after every step
        self.share, self.burst_s, self.slice_s = share, max(burst_s, slice_s), slice_s
        self._clock, self._sleep = clock, sleep
        #: when the node last answered a request (CommandClock.last); None: always paced
        self._commands_at = commands_at
        #: seconds the worker may still run before it pauses (a token bucket, at most burst_s)
        self.budget_s = self.burst_s
        self._since = clock()  # when the budget was last brought up to date

    def idle(self) -> None:
        """The worker waited for a plan until now: the wait refills the budget."""
        now = self._clock()
        self.budget_s = min(self.burst_s, self.budget_s + self.share * (now - self._since))
        self._since = now

    def __call__(self) -> None:
        """The worker ran since the last call: spend that time; when the budget is gone,
        sleep until it holds one slice again."""
        now = self._clock()
        if self._commands_at is not None and now - self._commands_at() > COMMANDS_RECENT_S:
            # no commands to protect: run unpaced, the budget full for when they come
            self.budget_s, self._since = self.burst_s, now
            return
        ran = now - self._since
        # running earns share of the time it takes and spends all of it
        self.budget_s = min(self.burst_s, self.budget_s - (1.0 - self.share) * ran)
        self._since = now
        if self.budget_s >= 0.0:
            return
        self._sleep((self.slice_s - self.budget_s) / self.share)
        self.budget_s, self._since = self.slice_s, self._clock()


def lower_priority(pid: int) -> None:
    """Let process ``pid`` (its main thread, and the threads it starts later) run only on CPU
    time no other process wants: SCHED_IDLE, where Linux has it, else nice PLAN_NICE. nice 5
    was tried first: on a busy 2-core machine the worker then still took a quarter of a core
    from the node's command thread and from the clients timing it."""
    try:
        os.sched_setscheduler(pid, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, pid, PLAN_NICE)


def read_answers(answers: Any, into: queue.SimpleQueue[PlanDone | WorkerGone]) -> None:
    """A thread of the node: read each answer from the worker's pipe (waiting in the read with
    the interpreter lock released) into ``into``, then WorkerGone when the worker has exited."""
    try:
        while True:
            into.put(answers.recv())
    except (EOFError, OSError):
        pass
    finally:
        answers.close()
        into.put(WorkerGone())


def serve_plans(jobs: Any, answers: Any, parent: int, commands: CommandClock | None = None) -> None:
    """The worker process: solve each job in turn and send its PlanDone on ``answers``, until
    None or the node is gone; paced while ``commands`` says the node is answering requests
    (always, without one)."""
    for sig in _GROUP_SIGNALS:  # the node stops it (a signal to the group reaches both)
        signal.signal(sig, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _GROUP_SIGNALS)  # (one pending is dropped)
    # No automatic collection: in a plan of 10^4 points the collector's passes over the
    # plan's live Results took 10-120 ms each, steps no pacing can split. The worker collects
    # after each plan is answered (its objects freed by then) and when it builds an engine.
    gc.disable()
    engine: Engine | None = None
    build_error: Exception | None = None  # why the last mechanism's engine was not built
    pace = Pacer(commands_at=None if commands is None else commands.last)
    while True:
        try:
            job = jobs.get(timeout=PARENT_CHECK_S)
        except queue.Empty:
            if os.getppid() != parent:
                return
            continue
        if job is None:
            return
        if isinstance(job, PlanMechanism):
            engine = None  # (the last mechanism's engine let go before the next is built)
            engine, build_error = build_engine(job)
            continue
        pace.idle()
        try:
            if engine is None:
                why = f'the plan worker could not build the engine: {build_error!r}'
                raise RuntimeError(why) from build_error
            if job.start is not None and engine.forward.adopt(job.start):
                engine.record(engine.forward, job.start)
            result = solve_job(job, engine, pace)
        except Exception as exc:  # a bug must not end the worker: the status says so
            why = f'internal error: {exc!r}'
            result = PlanDone(
                job.request,
                job.generation,
                job.stamp,
                False,
                why,
                {'request': job.request},
                None,
                traceback.format_exc(),
            )
        try:
            answers.send(result)
        except (BrokenPipeError, OSError):  # the node is gone
            return
        # the collector runs here, between plans, never inside one (gc.disable above)
        del job, result
        gc.collect()


def build_engine(mechanism: PlanMechanism) -> tuple[Engine | None, Exception | None]:
    """The worker's engine for ``mechanism``, or None and why it could not be built (each
    plan of it is answered with that). Built unpaced, before any plan of it: a build is one
    call, not steps to pace.

    The engine (its compiled plans) and the modules live until the next mechanism: they are
    taken out of the collector's sight (gc.freeze, as the node does at start-up). A full
    collection over them is one step that no pacing can split: 42-48 ms in a 3000-point
    four-bar plan (gc callbacks), against 2-8 ms frozen, and the plan's CPU time 0.54-0.56 s
    against 0.32 s. The last mechanism's objects are let back in and collected first (the
    caller has let its engine go): an engine holds reference cycles."""
    gc.unfreeze()
    gc.collect()
    try:
        engine, why = Engine(mechanism.mechanism, mechanism.settings), None
    except Exception as exc:
        engine, why = None, exc
    gc.freeze()
    return engine, why


def solve_job(job: PlanJob, engine: Engine, pace: Callable[[], None] | None = None) -> PlanDone:
    """Read, solve and write one plan on ``engine`` (its state is the same after); ``pace`` is
    called between its steps (a :class:`Pacer`)."""
    try:
        if job.point is None:
            msg: Any = read_joint_trajectory(job.raw, pace)
        else:
            msg = read_path(job.raw, pace)
    except CdrError as exc:
        kind = 'JointTrajectory' if job.point is None else 'Path'
        answer, times = TrajectoryAnswer(False, f'not a {kind}: {exc}'), list[int]()
    else:
        try:
            if job.point is None:
                answer, times = answer_trajectory_msg(engine, msg, job.frame_id, pace)
            else:
                answer, times = answer_path_msg(engine, job.point, msg, job.frame_id, pace)
        except CommandError as exc:
            answer, times = TrajectoryAnswer(False, str(exc)), []
    solved = None
    if answer.success:
        mech = engine.mech
        rows = answer.rows(mech, times, pace)
        solved = joint_trajectory_bytes(
            job.stamp, job.frame_id, [job.prefix + j for j in mech.output_joint_names], rows, pace
        )
        release(rows, pace)
    ok, message, values = trajectory_status_values(answer, job.request, pace)
    release(answer.results, pace)
    return PlanDone(job.request, job.generation, job.stamp, ok, message, values, solved)


#: solved points let go at a time (release): about a millisecond of freeing
RELEASE_CHUNK = 200


def release(items: list[Any], pace: Callable[[], None] | None = None) -> None:
    """Empty ``items`` a chunk at a time, ``pace`` called between the chunks: freeing 10^4
    solved points (their Results) at once was one step of 40-80 ms at a plan's end."""
    while items:
        del items[-RELEASE_CHUNK:]
        if pace is not None:
            pace()
