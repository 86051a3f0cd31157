"""A recorded hardware JointState stream read as the node's ``joint_states_in`` reads it
(docs/TOPICS.md, State completion): each message's values of the mechanism's inputs command it,
the robot's other joints are not read, and a message with none of the inputs (another robot's,
the node's own joint_states) is skipped without a row. Velocities are taken only where the
message has one per name and every input's is finite (joint_state_broadcaster fills a joint
without a velocity interface with NaN: positions alone command). A message whose positions do
not pair up with its names, or that names an input twice, is refused as the node refuses it
(request_checks.pick_refusal, its rule)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from ..request_checks import pick_refusal
from .reading import Commands


def completed_commands(
    data: Commands, inputs: Sequence[str], followers: Sequence[str] = ()
) -> tuple[Commands, dict[int, str]]:
    """``data``'s command-topic rows as the node's ``joint_states_in`` commands: each row
    reduced to the ``inputs`` it names, rows naming none dropped (``followers``, an input's
    <mimic> followers, count for the node's checks only); its target rows as they are. Also
    the rows (indices of the result) the node refuses, with its reason (their row names
    nothing: the replay refuses it without a change of state, and the caller puts the reason)."""
    wanted, picked_names = set(inputs), set(inputs) | set(followers)
    # per key: (columns kept, their names, the node's refusal); then the same keys untouched,
    # for target rows (at index len(keys) + k)
    reduced: list[tuple[tuple[int, ...], tuple[str, ...], str]] = []
    for k, names in enumerate(data.keys):
        why = pick_refusal(names, data.npos[k], picked_names) or ''  # the node's rule
        cols = () if why else tuple(i for i, n in enumerate(names) if n in wanted)
        reduced.append((cols, tuple(names[i] for i in cols), why))
    whole = len(reduced)
    for k, names in enumerate(data.keys):
        reduced.append((tuple(range(data.npos[k])), names, ''))
    n = data.n
    has_vel = data.vel_start.size >= n + 1
    rows: list[int] = []
    counts: list[int] = []
    vel_counts: list[int] = []
    values: list[np.ndarray] = []
    vels: list[np.ndarray] = []
    refused: dict[int, str] = {}
    row_keys: list[int] = []
    for i in range(n):
        k = int(data.key[i])
        r = k if int(data.topic[i]) == 0 else whole + k  # a target row: as recorded
        cols, _names, why = reduced[r]
        if r < whole and not cols and not why:
            continue  # none of the inputs: not the hardware's (the node ignores it)
        row_keys.append(r)
        if why:
            refused[len(rows)] = why
        rows.append(i)
        lo = int(data.start[i])
        values.append(data.values[lo : lo + data.npos[k]][list(cols)])
        counts.append(len(cols))
        taken = 0
        if has_vel and cols:
            v0, v1 = int(data.vel_start[i]), int(data.vel_start[i + 1])
            if r >= whole:  # (a target's velocities: as recorded)
                vels.append(data.vel_values[v0:v1])
                taken = v1 - v0
            elif v1 - v0 == len(data.keys[k]):
                v = data.vel_values[v0:v1][list(cols)]
                if all(math.isfinite(x) for x in v.tolist()):
                    vels.append(v)
                    taken = len(cols)
        vel_counts.append(taken)
    sel = np.asarray(rows, np.intp)
    # one key per distinct reduced name tuple and frame
    index: dict[tuple[tuple[str, ...], str], int] = {}
    remap = np.zeros(len(reduced), np.int32)
    keys: list[tuple[str, ...]] = []
    npos: list[int] = []
    frames: list[str] = []
    for k, (_cols, names, _why) in enumerate(reduced):
        frame = data.frame(k % whole) if whole else ''
        j = index.setdefault((names, frame), len(keys))
        if j == len(keys):
            keys.append(names)
            npos.append(len(names))
            frames.append(frame)
        remap[k] = j
    new_key = remap[np.asarray(row_keys, np.intp)] if row_keys else np.zeros(0, np.int32)
    start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    vel_start = np.concatenate([[0], np.cumsum(vel_counts)]).astype(np.int64)
    completed = replace(
        data,
        topic=data.topic[sel],
        log_ns=data.log_ns[sel],
        sec=data.sec[sel],
        nanosec=data.nanosec[sel],
        key=new_key.astype(np.int32),
        keys=keys,
        npos=npos,
        values=np.concatenate(values) if values else np.zeros(0),
        start=start,
        vel_values=np.concatenate(vels) if vels else np.zeros(0),
        vel_start=vel_start,
        frames=frames,
        skipped=data.skipped + n - len(rows),
        # (the node leaves a follower out from the first message naming it; here from the
        # start of the recording)
        state_inputs=frozenset(inputs)
        | (set(followers) & {n for names in data.keys for n in names}),
    )
    return completed, refused
