"""The node's plan topics: ``~/trajectory`` and ``~/target_path/<point>``, taken serialised.

On the executor thread, per message: refused by its length against the scene's bound
(plan_cdr), then by its first bytes (too many names or points, a bad stamp), or queued for the
:class:`~linkage_ros.plan_worker.PlanWorker`, or refused as dropped for load when its queue is
full. The worker's finished jobs are published here, on the executor thread as every other
answer is, by a timer that runs only while plans are in flight (rclpy's EventsExecutor, the
node's default, has no guard conditions).
"""

from __future__ import annotations

import collections
import traceback
from typing import TYPE_CHECKING, Any

from builtin_interfaces.msg import Time

from .plan_cdr import (
    CdrError,
    Stamp,
    path_bytes_bound,
    peek_plan,
    trajectory_bytes_bound,
)
from .plan_worker import PLAN_QUEUE, PlanJob, PlanWorker
from .trajectory import MAX_TRAJECTORY_POINTS, TrajectoryAnswer, too_many_points

#: how often finished plans are looked for while plans are in flight (s)
PLAN_POLL_S = 0.005

if TYPE_CHECKING:
    from .node import LinkageNode


class PlanRequests:
    """Plan requests of one node (see the module docstring). :meth:`destroy` ends the worker."""

    def __init__(self, node: LinkageNode):
        self.node = node
        self._done: collections.deque[PlanJob] = collections.deque()
        self._poll: Any = None  # the timer publishing finished plans, while any are in flight
        self._in_flight = 0  # plans queued or solved, not yet answered
        self.worker = PlanWorker(self._done.append)  # deque.append is atomic
        self.dropped = 0  # plans dropped for load

    def destroy(self) -> None:
        self.worker.stop()
        if self._poll is not None:
            self.node.destroy_timer(self._poll)
            self._poll = None

    def on_trajectory(self, raw: bytes) -> None:
        self._offer('trajectory', raw, None)

    def on_path(self, point: str, raw: bytes) -> None:
        self._offer(f'target_path/{point}', raw, point)

    # -- the executor thread -------------------------------------------------------------------
    def _offer(self, request: str, raw: bytes, point: str | None) -> None:
        """Refuse the plan from its size or first bytes, or queue it. Never raises."""
        node = self.node
        if node.outputs is None:  # no robot description yet
            node._refuse_waiting(request)
            return
        try:
            self._check_and_queue(request, raw, point)
        except Exception as exc:  # a bug must not take the node down: answer and keep going
            node.get_logger().error(
                f'internal error on {request}: {exc!r}\n' + traceback.format_exc()
            )
            node.outputs.internal_error(f'internal error: {exc!r}', request)

    def _check_and_queue(self, request: str, raw: bytes, point: str | None) -> None:
        node = self.node
        engine, mech = node._served_engine(), node._served_mech()
        kind = 'trajectory' if point is None else 'path'
        bound = (
            trajectory_bytes_bound(mech, MAX_TRAJECTORY_POINTS)
            if point is None
            else path_bytes_bound(node.frame_id, MAX_TRAJECTORY_POINTS)
        )
        if len(raw) > bound:
            self._refuse(
                request,
                Time(),
                f'the {kind} message is {len(raw)} bytes; one to scene {mech.name!r} is at most '
                f'{bound} bytes ({MAX_TRAJECTORY_POINTS} points, every name the scene has): '
                'send it in parts',
            )
            return
        try:
            peek = peek_plan(raw, point is not None, node.max_names)
        except CdrError as exc:
            self._refuse(
                request, Time(), f'not a {"JointTrajectory" if point is None else "Path"}: {exc}'
            )
            return
        stamp = Time(sec=peek.stamp.sec, nanosec=peek.stamp.nanosec)
        if peek.count > MAX_TRAJECTORY_POINTS:
            items = 'points' if point is None else 'poses'
            self._refuse(request, stamp, too_many_points(kind, peek.count, items))
            return
        stamp, bad_stamp = node._request_stamp(stamp)
        if bad_stamp:
            self._refuse(request, stamp, bad_stamp)
            return
        job = PlanJob(
            request,
            raw,
            engine,
            engine.last,
            node.frame_id,
            node.config.prefix,
            point,
            Stamp(stamp.sec, stamp.nanosec),
        )
        if self.worker.offer(job):
            self._in_flight += 1
            if self._poll is None:
                self._poll = node.create_timer(PLAN_POLL_S, self._publish_done)
        else:
            self.dropped += 1
            self._refuse(
                request,
                stamp,
                f'dropped for load: {PLAN_QUEUE} plans wait while another is solved; send it '
                'again later (commands keep their latency: plans are solved beside them)',
            )

    def _refuse(self, request: str, stamp: Time, why: str) -> None:
        outputs = self.node.outputs
        assert outputs is not None
        if stamp.sec == 0 and stamp.nanosec == 0:
            stamp = self.node.get_clock().now().to_msg()
        outputs.answer_trajectory(TrajectoryAnswer(False, why), stamp, request)

    def _publish_done(self) -> None:
        """The timer: publish every finished plan; the timer ends when none is in flight.
        Never raises."""
        node = self.node
        while self._done:
            job = self._done.popleft()
            self._in_flight -= 1
            outputs = node.outputs
            if outputs is None:
                continue
            try:
                stamp = Time(sec=job.stamp.sec, nanosec=job.stamp.nanosec)
                answer = job.answer
                if job.engine is not node.engine:
                    answer = TrajectoryAnswer(
                        False,
                        'the mechanism was replaced (a new robot description) while the plan '
                        'was solved: send it again',
                    )
                assert answer is not None
                if answer.reason.startswith('internal error'):
                    node.get_logger().error(f'{job.request}: {answer.reason}')
                    answer.reason = answer.reason.split('\n', 1)[0]
                outputs.answer_trajectory(answer, stamp, job.request, job.solved)
            except Exception as exc:  # a bug must not take the node down
                node.get_logger().error(
                    f'internal error on {job.request}: {exc!r}\n' + traceback.format_exc()
                )
                outputs.internal_error(f'internal error: {exc!r}', job.request)
        if self._in_flight <= 0 and self._poll is not None:
            node.destroy_timer(self._poll)
            self._poll = None
