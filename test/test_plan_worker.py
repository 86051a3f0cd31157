"""The plan worker (plan_worker.py) without a node: a plan held by a worker that dies is
answered, even when the next plan arrives before the node has looked for answers.

The worker is a real process; it is stopped (SIGSTOP) so that it holds the first plan, then
killed. Every plan must get exactly one answer: the held one an internal error that says the
worker exited, the next one its own answer from a new worker.
"""

from __future__ import annotations

import os
import signal
import time

import scenes

from linkage_ros.engine import Engine, EngineSettings
from linkage_ros.plan_cdr import Stamp
from linkage_ros.plan_worker import PlanJob, PlanWorker

#: long enough for a new worker's start-up (interpreter and imports) on a busy machine
ANSWER_WAIT_S = 120.0


def _job(engine: Engine, sec: int) -> PlanJob:
    # bytes that are no trajectory: the worker answers them with a refusal of its own
    return PlanJob(
        'trajectory', b'\x00\x01\x00\x00junk', 1, engine.last, 'base', '', None, Stamp(sec, 0)
    )


def test_a_plan_held_by_a_worker_that_died_is_answered_when_the_next_arrives_first():
    engine = Engine(scenes.load('four_bar'), EngineSettings())
    worker = PlanWorker()
    worker.start()
    try:
        first = worker.pid
        assert first is not None
        os.kill(first, signal.SIGSTOP)  # it holds the next plan, unanswered
        assert worker.offer(_job(engine, 1), engine)
        os.kill(first, signal.SIGKILL)
        deadline = time.monotonic() + ANSWER_WAIT_S
        while _alive(first):
            assert time.monotonic() < deadline
            time.sleep(0.01)
        # the next plan arrives before anyone looked for answers
        assert worker.offer(_job(engine, 2), engine)
        assert worker.pid not in (None, first), 'no new worker took the next plan'
        got = []
        while len(got) < 2 and time.monotonic() < deadline:
            got += worker.collect()
            time.sleep(0.02)
        assert [d.stamp.sec for d in got] == [1, 2], got
        held, after = got
        assert not held.ok and 'the plan worker exited' in held.message, held.message
        assert 'the plan worker exited' not in after.message, after.message
        assert worker.pending == 0
    finally:
        worker.stop()


def _alive(pid: int) -> bool:
    """True while ``pid`` has not died (a zombie, or no process at all, counts as dead)."""
    try:
        with open(f'/proc/{pid}/stat') as fh:
            return fh.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except FileNotFoundError:
        return False
