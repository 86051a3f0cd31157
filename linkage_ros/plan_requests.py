"""The node's plan topics: ``~/trajectory`` and ``~/target_path/<point>``, taken serialised.

On the executor thread, per message: refused by its length against the scene's bound
(plan_cdr), then by its first bytes (too many names or points, a bad stamp), or queued for the
:class:`~linkage_ros.plan_worker.PlanWorker`, or refused as dropped for load when its queue is
full. The worker's finished plans are published here, on the executor thread as every other
answer is, by a timer that runs only while plans are in flight.
"""

from __future__ import annotations

import traceback
from typing import Any

from builtin_interfaces.msg import Time

from .engine import Engine
from .node_protocol import ServingNode
from .plan_cdr import (
    CdrError,
    Stamp,
    path_bytes_bound,
    peek_plan,
    size_refusal,
    trajectory_bytes_bound,
)
from .plan_worker import PLAN_QUEUE, CommandClock, PlanJob, PlanWorker
from .trajectory import (
    MAX_TRAJECTORY_POINTS,
    TrajectoryAnswer,
    too_many_points,
    trajectory_status_values,
)

#: how often finished plans are looked for while plans are in flight (s)
PLAN_POLL_S = 0.02


class PlanRequests:
    """Plan requests of one node (see the module docstring). :meth:`destroy` ends the worker."""

    def __init__(self, node: ServingNode, commands: CommandClock | None = None):
        self.node = node
        self._poll: Any = None  # the timer publishing finished plans, while any are in flight
        #: ``commands``: when the node last answered a request (its worker paces itself by it)
        self.worker = PlanWorker(commands=commands)
        self.worker.start()  # now, not beside the first plan's commands
        #: the engine served and its generation (a robot description replaces it: +1)
        self._engine: Engine | None = None
        self._generation = 0
        self.dropped = 0  # plans dropped for load

    def destroy(self) -> None:
        self.worker.stop()
        if self._poll is not None:
            self.node.destroy_timer(self._poll)
            self._poll = None

    def serve(self, engine: Engine) -> None:
        """The node serves ``engine`` now (at start-up, or a new robot description): a new
        generation, whose mechanism the worker gets at once (PlanWorker.prepare)."""
        if engine is not self._engine:
            self._engine, self._generation = engine, self._generation + 1
        self.worker.prepare(self._generation, engine)

    def on_trajectory(self, raw: bytes) -> None:
        self._offer('trajectory', raw, None)

    def on_path(self, point: str, raw: bytes) -> None:
        self._offer(f'target_path/{point}', raw, point)

    # -- the executor thread -------------------------------------------------------------------
    def _offer(self, request: str, raw: bytes, point: str | None) -> None:
        """Refuse the plan from its size or first bytes, or queue it. Never raises."""
        node = self.node
        if node.outputs is None:  # no robot description yet
            node.requests.refuse_waiting(request)
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
        engine, mech = node.requests.served_engine(), node.requests.served_mech()
        kind = 'trajectory' if point is None else 'path'
        bound = (
            trajectory_bytes_bound(mech, MAX_TRAJECTORY_POINTS)
            if point is None
            else path_bytes_bound(node.frame_id, MAX_TRAJECTORY_POINTS)
        )
        if len(raw) > bound:
            why = size_refusal(kind, len(raw), mech.name, bound, MAX_TRAJECTORY_POINTS)
            self._refuse(request, why)
            return
        try:
            peek = peek_plan(raw, point is not None, node.max_names)
        except CdrError as exc:
            self._refuse(request, f'not a {"JointTrajectory" if point is None else "Path"}: {exc}')
            return
        stamp = Time(sec=peek.stamp.sec, nanosec=peek.stamp.nanosec)
        if peek.count > MAX_TRAJECTORY_POINTS:
            items = 'points' if point is None else 'poses'
            self._refuse(request, too_many_points(kind, peek.count, items))
            return
        stamp, bad_stamp = node.requests.request_stamp(stamp)
        if bad_stamp:
            self._refuse(request, bad_stamp)
            return
        job = PlanJob(
            request,
            raw,
            self._generation,
            engine.last,
            node.frame_id,
            node.config.prefix,
            point,
            Stamp(stamp.sec, stamp.nanosec),
        )
        if self.worker.offer(job, engine):
            if self._poll is None:
                self._poll = node.create_timer(PLAN_POLL_S, self._publish_done)
        else:
            self.dropped += 1
            self._refuse(
                request,
                f'dropped for load: {PLAN_QUEUE} plans wait while another is solved; send it '
                'again later (commands keep their latency: plans are solved beside them)',
            )

    def _refuse(self, request: str, why: str) -> None:
        """One ERROR status (a plan's status carries no stamp)."""
        outputs = self.node.outputs
        assert outputs is not None
        ok, message, values = trajectory_status_values(TrajectoryAnswer(False, why), request)
        outputs.answer_trajectory(ok, message, values, request)

    def _publish_done(self) -> None:
        """The timer: publish every finished plan; the timer ends when none is in flight.
        Never raises."""
        node = self.node
        for done in self.worker.collect():
            outputs = node.outputs
            if outputs is None:
                continue
            try:
                ok, message, values, solved = done.ok, done.message, done.values, done.solved
                if done.generation != self._generation or node.engine is not self._engine:
                    ok, message, values = trajectory_status_values(
                        TrajectoryAnswer(
                            False,
                            'the mechanism was replaced (a new robot description) while the '
                            'plan was solved: send it again',
                        ),
                        done.request,
                    )
                if done.error:
                    node.get_logger().error(f'{done.request}: {message}\n{done.error}')
                outputs.answer_trajectory(ok, message, values, done.request, solved)
            except Exception as exc:  # a bug must not take the node down
                node.get_logger().error(
                    f'internal error on {done.request}: {exc!r}\n' + traceback.format_exc()
                )
                outputs.internal_error(f'internal error: {exc!r}', done.request)
        if self.worker.pending <= 0 and self._poll is not None:
            node.destroy_timer(self._poll)
            self._poll = None
