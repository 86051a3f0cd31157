"""linkage bag refuses a recorded plan the node would refuse from its size or first bytes,
with the node's words, without decoding it (a 10^6-point trajectory was read whole, 1.67 GB,
only to be refused)."""

from __future__ import annotations

import csv

import test_fleet as tf

from linkage_ros.bag import main, plans
from linkage_ros.core.model import Scene
from linkage_ros.plan_cdr import size_refusal, trajectory_bytes_bound
from linkage_ros.trajectory import MAX_TRAJECTORY_POINTS, too_many_points


def test_oversized_plans_are_refused_unread(tmp_path, monkeypatch, capsys):
    many = [[0.01 * (k % 100)] for k in range(MAX_TRAJECTORY_POINTS + 1)]
    ok = [[0.1 * k] for k in range(5)]
    tf.write_fleet_bag(tmp_path / 'bag', 'mcap', 50, 0.3, trajs=[ok, many])
    decoded = []
    real = plans.decode_plan

    def counting(raw, typename, ts):
        decoded.append(len(raw))
        return real(raw, typename, ts)

    monkeypatch.setattr(plans, 'decode_plan', counting)
    out = tmp_path / 'out.csv'
    code = main(
        [
            str(tmp_path / 'bag'),
            *('--scene', str(tf.SCENE), '--command-topic', '/cmd', '--trajectory-topic', '/traj'),
            *('--out', str(out), '--no-progress'),
        ]
    )
    capsys.readouterr()
    assert code == 0
    assert len(decoded) == 1  # the 5-point trajectory only: the other was refused unread
    with open(plans.plans_csv_path(str(out)), newline='') as fh:
        rows = list(csv.DictReader(fh))
    reasons = {r.get('reason') or r.get('status') for r in rows}
    assert any(too_many_points('trajectory', len(many), 'points') in (x or '') for x in reasons)


def test_the_size_bound_is_the_nodes():
    mech = Scene.from_yaml(tf.SCENE).mechanism
    bound = trajectory_bytes_bound(mech, MAX_TRAJECTORY_POINTS)
    raw = b'\x00\x01\x00\x00' + bytes(bound)  # longer than any request to the scene
    why = plans.plan_refusal(raw, tf.TRAJ, mech, 'base_link')
    assert why == size_refusal('trajectory', len(raw), mech.name, bound, MAX_TRAJECTORY_POINTS)
