"""Writing the results as a new rosbag2 (joint states, points, status)."""

from __future__ import annotations

import contextlib
import os
import shutil
import struct
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..answer_cdr import JointStateBytes, PointStampedBytes
from ..cdr import string_block
from ..outputs import staging_name
from ..stamps import NSEC_PER_SEC, OwnStamps
from ..trajectory import TrajectoryAnswer, trajectory_status_values
from .common import (
    DIAGNOSTIC_STATUS,
    JOINT_STATE,
    NODE_NAME,
    POINT_STAMPED,
    BagError,
    node_topic,
)
from .plans import TRAJECTORY, PlanRequest
from .progress import Progress
from .reading import Commands, exc_text
from .results import Results

# ---- writing: rosbag2 ----------------------------------------------------------------------


def _joint_state_template(names, frame_id):
    """A JointState of ``names`` with zero stamp and positions (the node's writer), and the
    byte offset of its positions."""
    w = JointStateBytes(frame_id, names)
    return np.frombuffer(w.write(0, 0, [0.0] * len(names)), np.uint8), w.plain_offsets[0]


def _joint_state_rates_template(names, frame_id):
    """A JointState with a position and a velocity per name: (bytes, position offset, velocity
    offset)."""
    w = JointStateBytes(frame_id, names)
    zeros = [0.0] * len(names)
    pos, vel = w.rates_offsets
    return np.frombuffer(w.write(0, 0, zeros, zeros), np.uint8), pos, vel


def _point_template(frame_id):
    w = PointStampedBytes(frame_id)
    return np.frombuffer(w.write(0, 0, 0.0, 0.0, 0.0), np.uint8), w.xyz_offset


_LEN = [struct.pack('<I', k + 1) for k in range(256)]
_PAD = [b'\x00' * (1 + (-(k + 1)) % 4) for k in range(256)]


def _float_blocks(values: list[float]) -> list[bytes]:
    """CDR string blocks of repr(value) (what the node's status key-values hold)."""
    out = []
    for x in values:
        b = repr(x).encode()
        k = len(b)
        out.append(_LEN[k] + b + _PAD[k])
    return out


class _StatusWriter:
    """Serialises diagnostic_msgs/DiagnosticStatus as conversions.result_to_status builds it:
    name '<node>: <scene>', hardware_id '<scene>', OK + 'ok' + residual, branch,
    branch_defined, margin, solver, iterations[, cond][, held], request; or ERROR + the
    reason + request."""

    OK_LEVEL, ERROR_LEVEL = 0, 2

    def __init__(self, name: str, hardware_id: str = ''):
        self.name = string_block(name)
        self.hw = string_block(hardware_id)
        self.cache: dict[str, bytes] = {}
        self.parts: dict[tuple[Any, ...], tuple[bytes, bytes, bytes, bytes]] = {}

    def blk(self, s: str) -> bytes:
        b = self.cache.get(s)
        if b is None:
            b = self.cache[s] = string_block(s)
        return b

    def _head(self, level: int, message: str, count: int) -> bytes:
        return b''.join(
            [
                b'\x00\x01\x00\x00',
                bytes([level, 0, 0, 0]),
                self.name,
                self.blk(message),
                self.hw,
                struct.pack('<I', count),
            ]
        )

    def ok_parts(
        self,
        has_cond: bool,
        branch: str,
        bdef: bool,
        solver: str,
        iterations: int,
        request: str,
        held: str = '',
    ):
        """The constant pieces of an OK status around the residual and margin (and cond)."""
        key = (has_cond, branch, bdef, solver, iterations, request, held)
        hit = self.parts.get(key)
        if hit is None:
            k = self.blk
            count = 7 + bool(has_cond) + bool(held)
            head = self._head(self.OK_LEVEL, 'ok', count) + k('residual')
            mid = b''.join(
                [
                    k('branch'),
                    k(branch),
                    k('branch_defined'),
                    k('true' if bdef else 'false'),
                    k('margin'),
                ]
            )
            tail = b''.join([k('solver'), k(solver), k('iterations'), k(str(iterations))])
            end = (k('held') + k(held) if held else b'') + k('request') + k(request)
            hit = self.parts[key] = (head, mid, tail + (k('cond') if has_cond else b''), end)
        return hit

    def with_velocity(self, parts: tuple[bytes, ...], held: str, request: str, note: str):
        """ok_parts' pieces with the 'velocity' key-value before the request (one more
        key-value: the count in the head goes up by one)."""
        head, mid, tail, _ = parts
        k = self.blk
        end = (k('held') + k(held) if held else b'') + k('velocity') + string_block(note)
        return self._one_more(head), mid, tail, end + k('request') + k(request)

    def with_mode_change(self, parts: tuple[bytes, ...], change: str):
        """ok_parts' pieces with the 'mode_change' key-value after cond (request_checks'
        order: before held, velocity and request), one more key-value in the count."""
        head, mid, tail, end = parts
        return self._one_more(head), mid, tail, self.blk('mode_change') + self.blk(change) + end

    def _one_more(self, head: bytes) -> bytes:
        """An OK status's head with its key-value count one up."""
        count_at = len(head) - len(self.blk('residual')) - 4
        count = struct.unpack_from('<I', head, count_at)[0] + 1
        return head[:count_at] + struct.pack('<I', count) + head[count_at + 4 :]

    def error(self, reason: str, request: str) -> bytes:
        return b''.join(
            [self._head(self.ERROR_LEVEL, reason, 1), self.blk('request'), self.blk(request)]
        )


class ResultBag:
    """A new rosbag2 with the node's topics (common.output_topics: /joint_states,
    /linkage_node/points/<name>, /linkage_node/status; each renamed as ``remap`` says),
    written in a staging folder beside the target and renamed into place by :meth:`close`
    (a run cut short, even by SIGKILL, leaves no half bag under the output's name).

    :meth:`add_plan` writes one answered trajectory or path as it is solved
    (/linkage_node/solved_trajectory on success and one status, at its bag time: a bag of many
    long plans never holds more than one); :meth:`write_commands` the commands' answers.
    Any failure removes the staging folder (:meth:`abort`)."""

    def __init__(
        self,
        path: Path | str,
        mech: Any,
        frame_id: str,
        storage: str | None,
        plans: bool = False,
        status_name: str | None = None,
        remap: Mapping[str, str] | None = None,
        publish_inputs: bool = False,
    ):
        from rosbags.rosbag2 import Writer
        from rosbags.rosbag2.enums import StoragePlugin
        from rosbags.typesys import Stores, get_typestore

        plugin = StoragePlugin.MCAP if (storage or 'mcap') == 'mcap' else StoragePlugin.SQLITE3
        self.ts = ts = get_typestore(Stores.ROS2_JAZZY)
        self.path, self.mech, self.frame_id = path, mech, frame_id
        #: state completion: joint_states carry the inputs too (the node's publish_inputs)
        self.publish_inputs = publish_inputs
        self.name = status_name if status_name is not None else f'{NODE_NAME}: {mech.name}'
        self.final = final = Path(path)
        self.stage = stage = final.parent / staging_name(final.name)
        self.writer: Any = None
        try:
            stage.mkdir()
            self.writer = Writer(stage / final.name, version=9, storage_plugin=plugin)
            self.writer.open()
        except Exception as exc:  # noqa: BLE001
            shutil.rmtree(stage, ignore_errors=True)
            raise BagError(f'output {path}: cannot create the bag ({exc_text(exc)})') from None
        names = dict(remap or {})

        def topic(default: str) -> str:
            return names.get(default, default)

        with self._failing():
            w = self.writer
            self.c_js = w.add_connection(topic('/joint_states'), JOINT_STATE, typestore=ts)
            self.c_pts = [
                w.add_connection(topic(node_topic(f'points/{p}')), POINT_STAMPED, typestore=ts)
                for p in mech.outputs
            ]
            status = topic(node_topic('status'))
            self.c_st = w.add_connection(status, DIAGNOSTIC_STATUS, typestore=ts)
            self.c_traj = (
                w.add_connection(topic(node_topic('solved_trajectory')), TRAJECTORY, typestore=ts)
                if plans
                else None
            )

    @contextlib.contextmanager
    def _failing(self) -> Iterator[None]:
        """A failure inside: the bag is abandoned (nothing kept) and the error said plainly."""
        try:
            yield
        except BaseException as exc:
            self.abort()
            if isinstance(exc, (BagError, OSError)) or not isinstance(exc, Exception):
                raise
            # sqlite3 ('database or disk is full'), rosbags' WriterError, ...
            raise BagError(
                f'output {self.path}: cannot write the bag ({exc_text(exc)}); nothing was kept'
            ) from None

    def add_plan(self, req: PlanRequest) -> None:
        """One answered trajectory or path: its solved trajectory (on success) and its status,
        at its bag time."""
        ans = req.answer
        assert ans is not None  # answered by the replay
        ts = self.ts
        with self._failing():
            if ans.success and self.c_traj is not None:
                msg = _trajectory_msg(ts, req, self.mech, self.frame_id)
                self.writer.write(self.c_traj, req.log_ns, ts.serialize_cdr(msg, TRAJECTORY))
            msg = _plan_status_msg(ts, ans, self.name, req.request, self.mech.name)
            self.writer.write(self.c_st, req.log_ns, ts.serialize_cdr(msg, DIAGNOSTIC_STATUS))

    def write_commands(
        self,
        data: Commands,
        res: Results,
        progress: Progress | None = None,
        block: int = 100_000,
    ) -> None:
        """One set of messages per command, each logged at its command's bag time, in the
        node's order (joint_states, points, status)."""
        with self._failing():
            _write_commands(self, data, res, progress or Progress(False), block)

    def close(self) -> None:
        """The bag, complete, under its name."""
        with self._failing():
            self.writer.close()
            os.rename(self.stage / self.final.name, self.final)
            self.stage.rmdir()

    def abort(self) -> None:
        """Nothing kept: the staging folder goes."""
        with contextlib.suppress(Exception):
            self.writer.abort()
        shutil.rmtree(self.stage, ignore_errors=True)


def _write_commands(out: ResultBag, data: Commands, res: Results, progress: Progress, block):
    mech, frame_id = out.mech, out.frame_id
    n = data.n
    # a robot description's own names where it has them; under state completion without the
    # joints the hardware publishes (the node's answers to joint_states_in leave them out)
    published = mech.output_joint_names
    omit = data.state_inputs if data.state_inputs is not None and not out.publish_inputs else ()
    kept = [i for i, j in enumerate(published) if j not in omit]
    joints = [published[i] for i in kept]
    progress.start('writing', n)
    sec, nsec = answer_stamps(data, res.ok)
    js_t, js_off = _joint_state_template(joints, frame_id)
    jv_t, jv_pos, jv_vel = _joint_state_rates_template(joints, frame_id)
    pt_t, pt_off = _point_template(frame_id)
    status = _StatusWriter(out.name, mech.name)
    requests = list(data.requests)
    if data.state_inputs is not None:  # (its commands are joint_states_in's)
        requests[0] = 'joint_states_in'

    write, c_js, c_pts, c_st = out.writer.write, out.c_js, out.c_pts, out.c_st
    for a in range(0, n, block):
        b = min(n, a + block)
        okr = a + np.flatnonzero(res.ok[a:b])
        js = _stamped_rows(js_t, okr, sec, nsec)
        if joints and okr.size:
            scene = {j: res.joints[j][okr] for j in mech.joint_names}
            cols = mech.output_joints(scene, {x: res.inputs[x][okr] for x in mech.actuators})
            vals = np.stack([np.broadcast_to(cols[i], okr.shape) for i in kept], axis=1).astype(
                '<f8'
            )
            js[:, js_off : js_off + 8 * len(joints)] = vals.view(np.uint8).reshape(okr.size, -1)
        js_rows = _rows_bytes(js)
        rated = np.flatnonzero(res.velocity_ok[okr]) if res.has_rates and joints else okr[:0]
        if rated.size:  # the node's joint_states with every joint's velocity
            vrows = okr[rated]
            jv = _stamped_rows(jv_t, vrows, sec, nsec)
            scene = {j: res.joints[j][vrows] for j in mech.joint_names}
            rates = {j: res.joint_rates[j][vrows] for j in mech.joint_names}
            for off, every in (
                (
                    jv_pos,
                    mech.output_joints(scene, {x: res.inputs[x][vrows] for x in mech.actuators}),
                ),
                (jv_vel, mech.output_joint_rates(rates)),
            ):
                vals = np.stack(
                    [np.broadcast_to(every[i], vrows.shape) for i in kept], axis=1
                ).astype('<f8')
                jv[:, off : off + 8 * len(joints)] = vals.view(np.uint8).reshape(vrows.size, -1)
            for i, raw in zip(rated.tolist(), _rows_bytes(jv)):
                js_rows[i] = raw
        pt_rows = []
        for p in mech.outputs:
            arr = _stamped_rows(pt_t, okr, sec, nsec)
            xyz = np.zeros((okr.size, 3), '<f8')
            xyz[:, :2] = res.points[p][okr]
            arr[:, pt_off : pt_off + 24] = xyz.view(np.uint8).reshape(okr.size, 24)
            pt_rows.append(_rows_bytes(arr))
        statuses = _status_rows(status, res, data.topic, requests, a, b, okr)
        ok = res.ok[a:b].tolist()
        log = data.log_ns[a:b].tolist()
        j = 0
        for i in range(b - a):
            t = log[i]
            if ok[i]:
                write(c_js, t, js_rows[j])
                for conn, rows in zip(c_pts, pt_rows):
                    write(conn, t, rows[j])
                j += 1
            write(c_st, t, statuses[i])
        progress.update(b)
    progress.finish()


def answer_stamps(data: Commands, ok: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(sec, nanosec) of each row's answers: the command's stamp; a zero one, the stamp the
    node chooses with the bag receive time as its clock (stamps.OwnStamps: strictly after the
    joint_states before it, so two answers received in one nanosecond, or after a client's
    stamp a little ahead, do not repeat a stamp or go back for tf). Rows in bag order; ``ok``
    says which answers published joint_states."""
    zero = data.stamp_zero
    if not zero.any():
        return data.sec.astype('<i4'), data.nanosec.astype('<u4')
    ns = data.sec.astype(np.int64) * NSEC_PER_SEC + data.nanosec.astype(np.int64)
    own = OwnStamps()
    for i, (is_zero, now, good) in enumerate(zip(zero.tolist(), data.log_ns.tolist(), ok.tolist())):
        if is_zero:
            ns[i] = own.choose(now)
        if good:
            own.published(int(ns[i]))
    return (ns // NSEC_PER_SEC).astype('<i4'), (ns % NSEC_PER_SEC).astype('<u4')


def write_bag(
    path: Path,
    data: Commands,
    res: Results,
    mech,
    frame_id: str,
    storage: str | None,
    progress: Progress | None = None,
    status_name: str | None = None,
    block: int = 100_000,
    plans: Sequence[PlanRequest] = (),
    remap: Mapping[str, str] | None = None,
):
    """A new rosbag2 (:class:`ResultBag`) with every command's answer and each recorded
    trajectory or path of ``plans`` (answered already), at once."""
    out = ResultBag(path, mech, frame_id, storage, bool(plans), status_name, remap)
    out.write_commands(data, res, progress, block)
    for req in plans:
        out.add_plan(req)
    out.close()


def _stamped_rows(template: np.ndarray, rows: np.ndarray, sec, nsec) -> np.ndarray:
    """The message template once per row, with each row's header stamp."""
    out = np.tile(template, (rows.size, 1))
    out[:, 4:8] = sec[rows].view(np.uint8).reshape(rows.size, 4)
    out[:, 8:12] = nsec[rows].view(np.uint8).reshape(rows.size, 4)
    return out


def _status_rows(status: _StatusWriter, res: Results, topic, requests, a, b, okr) -> list[bytes]:
    """Serialised DiagnosticStatus of rows a..b-1 (okr: their successful rows)."""
    res_blk = _float_blocks(res.residual[okr].tolist())
    mar_blk = _float_blocks(res.margin[okr].tolist())
    cond = res.cond[okr]
    has_cond = ~np.isnan(cond)
    cond_blk = _float_blocks(cond[has_cond].tolist()) if has_cond.any() else []
    bcode, bnames = res.branch_code[okr].tolist(), res.branch_names
    scode, snames = res.solver_code[okr].tolist(), res.solver_names
    hcode, hnames = res.held_code[okr].tolist(), res.held_names
    bdef = res.branch_defined[okr].tolist()
    iters = res.iterations[okr].tolist()
    hc = has_cond.tolist()
    notes = [res.velocity_note.get(g) for g in okr.tolist()]
    ok = res.ok[a:b].tolist()
    tops = topic[a:b].tolist()
    out: list[bytes] = []
    j = c = 0
    for i in range(b - a):
        req = requests[tops[i]]
        if ok[i]:
            parts = status.ok_parts(
                hc[j], bnames[bcode[j]], bdef[j], snames[scode[j]], iters[j], req, hnames[hcode[j]]
            )
            note = notes[j]
            if note is not None:
                parts = status.with_velocity(parts, hnames[hcode[j]], req, note)
            change = res.mode_change.get(int(okr[j])) if res.mode_change else None
            if change:
                parts = status.with_mode_change(parts, change)
            head, mid, tail, end = parts
            if hc[j]:
                out.append(b''.join([head, res_blk[j], mid, mar_blk[j], tail, cond_blk[c], end]))
                c += 1
            else:
                out.append(b''.join([head, res_blk[j], mid, mar_blk[j], tail, end]))
            j += 1
        else:
            out.append(status.error(res.reason[a + i] or 'failed', req))
    return out


def _rows_bytes(arr: np.ndarray) -> list[bytes]:
    """The rows of a 2-D uint8 array as bytes objects."""
    if not arr.shape[0]:
        return []
    width = arr.shape[1]
    buf = arr.tobytes()
    return [buf[k : k + width] for k in range(0, len(buf), width)]


def _trajectory_msg(ts: Any, req: PlanRequest, mech: Any, frame_id: str) -> Any:
    """The node's ~/solved_trajectory for a recorded request (what
    plan_cdr.joint_trajectory_bytes writes, as rosbags objects): every joint at every point,
    stamp and time_from_start of the request, velocities when every point has them."""
    t = ts.types
    ans = req.answer
    assert ans is not None
    empty = np.zeros(0, np.float64)
    points = [
        t['trajectory_msgs/msg/JointTrajectoryPoint'](
            positions=np.array(positions, np.float64),
            velocities=np.array(velocities, np.float64),
            accelerations=empty,
            effort=empty,
            time_from_start=t['builtin_interfaces/msg/Duration'](sec=sec, nanosec=nanosec),
        )
        for positions, velocities, sec, nanosec in ans.rows(mech, req.times_ns)
    ]
    header = t['std_msgs/msg/Header'](
        stamp=t['builtin_interfaces/msg/Time'](sec=req.stamp[0], nanosec=req.stamp[1]),
        frame_id=frame_id,
    )
    return t['trajectory_msgs/msg/JointTrajectory'](
        header=header, joint_names=list(mech.output_joint_names), points=points
    )


def _plan_status_msg(
    ts: Any, ans: TrajectoryAnswer, name: str, request: str, hardware_id: str
) -> Any:
    t = ts.types
    ok, message, values = trajectory_status_values(ans, request)
    return t['diagnostic_msgs/msg/DiagnosticStatus'](
        level=0 if ok else 2,
        name=name,
        message=message,
        hardware_id=hardware_id,
        values=[t['diagnostic_msgs/msg/KeyValue'](key=k, value=v) for k, v in values.items()],
    )
