"""The plan worker's Pacer on a simulated clock: over a long plan the worker runs at most its
share of the time, a short plan after a wait is not slowed, and a pause is never shorter than
a slice's worth (the worker must not wake thousands of times a second).

The oracle is the time line itself: the steps the test runs and the sleeps the pacer asks for,
added up by the test."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from linkage_ros.plan_worker import COMMANDS_RECENT_S, Pacer


class Timeline:
    """A clock the test advances: running steps, and the pacer's sleeps (recorded)."""

    def __init__(self) -> None:
        self.now = 100.0
        self.sleeps: list[float] = []

    def clock(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds > 0
        self.sleeps.append(seconds)
        self.now += seconds


def run_plan(pacer: Pacer, line: Timeline, steps: int, step_s: float) -> float:
    """Run ``steps`` steps of ``step_s`` each, the pacer called after each; the run time."""
    pacer.idle()
    for _ in range(steps):
        line.now += step_s
        pacer()
    return steps * step_s


@settings(max_examples=100, deadline=None)
@given(
    share=st.floats(0.05, 0.9),
    step_s=st.floats(1e-5, 2e-3),
    steps=st.integers(500, 5000),
    burst_s=st.floats(0.0, 0.2),
    slice_s=st.floats(1e-3, 2e-2),
)
def test_a_long_plan_runs_at_most_its_share_of_the_time(share, step_s, steps, burst_s, slice_s):
    line = Timeline()
    pacer = Pacer(share, burst_s, slice_s, clock=line.clock, sleep=line.sleep)
    start = line.now
    ran = run_plan(pacer, line, steps, step_s)
    elapsed = line.now - start
    slept = sum(line.sleeps)
    assert elapsed == pytest.approx(ran + slept)
    # at most the share, plus what the burst (at least a slice) and its last step allow
    allowance = max(burst_s, slice_s) / (1 - share) + step_s
    assert ran <= share * elapsed + allowance + 1e-9
    # and not much less: it sleeps no longer than it must (the last pause may end the plan)
    if line.sleeps:
        assert ran >= share * (elapsed - line.sleeps[-1]) - step_s - 1e-9
    for pause in line.sleeps:  # never a wake-up per step
        assert pause >= slice_s / share - 1e-12


@settings(max_examples=100, deadline=None)
@given(share=st.floats(0.05, 0.9), step_s=st.floats(1e-5, 1e-3), burst_s=st.floats(0.01, 0.2))
def test_a_short_plan_after_a_wait_is_not_slowed(share, step_s, burst_s):
    line = Timeline()
    pacer = Pacer(share, burst_s, 0.005, clock=line.clock, sleep=line.sleep)
    line.now += burst_s / share  # waited long enough to refill the whole burst
    steps = int(0.99 * burst_s / ((1 - share) * step_s))
    run_plan(pacer, line, steps, step_s)
    assert line.sleeps == []


def test_back_to_back_plans_share_one_budget():
    # a flood of plans must not get a fresh burst each: the wait between them is what refills
    line = Timeline()
    pacer = Pacer(0.2, 0.1, 0.005, clock=line.clock, sleep=line.sleep)
    start = line.now
    ran = sum(run_plan(pacer, line, 1000, 1e-3) for _ in range(10))
    assert ran <= 0.2 * (line.now - start) + 0.1 / 0.8 + 1e-3


@pytest.mark.parametrize('share', [0.0, -0.1, 1.5])
def test_a_share_outside_0_1_is_refused(share):
    with pytest.raises(ValueError, match='share'):
        Pacer(share)


@settings(max_examples=60, deadline=None)
@given(
    step_s=st.floats(1e-5, 1e-3),
    steps=st.integers(500, 5000),
    quiet_for=st.floats(COMMANDS_RECENT_S * 1.01, 100.0),
)
def test_with_no_commands_coming_a_plan_is_not_paced(step_s, steps, quiet_for):
    # the node answered its last request quiet_for seconds before the plan: nothing to protect
    line = Timeline()
    last = line.now - quiet_for
    pacer = Pacer(0.2, 0.1, 0.005, clock=line.clock, sleep=line.sleep, commands_at=lambda: last)
    run_plan(pacer, line, steps, step_s)
    assert line.sleeps == []


@settings(max_examples=60, deadline=None)
@given(step_s=st.floats(1e-5, 1e-3), steps=st.integers(500, 5000))
def test_while_commands_come_a_plan_is_paced(step_s, steps):
    # the node answers a request every 2 ms of the plan (500 Hz): paced as without the gate
    line = Timeline()
    start = line.now
    pacer = Pacer(
        0.2, 0.1, 0.005, clock=line.clock, sleep=line.sleep, commands_at=lambda: line.now - 0.002
    )
    ran = run_plan(pacer, line, steps, step_s)
    assert ran <= 0.2 * (line.now - start) + 0.1 / 0.8 + step_s + 1e-9


def test_commands_stopping_mid_plan_unpace_it():
    # commands for the first 2 s of the plan, none after: paced, then at full speed
    line = Timeline()
    stop = line.now + 2.0
    began: list[float] = []
    sleep = line.sleep

    def sleep_logged(seconds: float) -> None:
        began.append(line.now)
        sleep(seconds)

    pacer = Pacer(
        0.2,
        0.1,
        0.005,
        clock=line.clock,
        sleep=sleep_logged,
        commands_at=lambda: min(line.now, stop),
    )
    start = line.now
    ran = run_plan(pacer, line, 5000, 1e-3)  # 5 s of steps
    assert began and min(began) < stop  # paced while the commands came
    assert max(began) <= stop + COMMANDS_RECENT_S + 1e-3  # and never once they had stopped
    # the steps after the commands stopped ran back to back: the plan ended as soon as it could
    done_by_stop = 0.2 * (stop - start) + 0.1 / 0.8
    assert line.now - stop <= ran - done_by_stop + COMMANDS_RECENT_S + 0.02
