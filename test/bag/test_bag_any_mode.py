"""`linkage bag --target-any-mode-topic`: the node's ~/target_any_mode replayed as the node
answers it (a new user: a recorded session whose any-mode target moved a crank-rocker to its
other circuit could not be replayed, and every answer after it differed from the node's).
Oracle: the crank-rocker's other circuit written here (B on the right of A -> O4)."""

from __future__ import annotations

import math

from test_bag import (
    COUPLER,
    CRANK,
    GROUND,
    ROCKER,
    joint_state,
    read_csv,
    read_out_bag,
    run_bag,
    write_bag,
)


def mirrored_b(theta2: float) -> tuple[float, float]:
    """B of the crank-rocker at crank angle theta2 on the right of A -> O4 (the other circuit
    than the drawing's)."""
    ax, ay = CRANK * math.cos(theta2), CRANK * math.sin(theta2)
    dx, dy = GROUND - ax, -ay
    d = math.hypot(dx, dy)
    ux, uy = dx / d, dy / d
    along = (COUPLER**2 - ROCKER**2 + d**2) / (2 * d)
    h = -math.sqrt(COUPLER**2 - along**2)
    return ax + along * ux - h * uy, ay + along * uy + h * ux


def joint_b(theta2: float) -> float:
    """The joint B (rocker less coupler angle) of that configuration."""
    ax, ay = CRANK * math.cos(theta2), CRANK * math.sin(theta2)
    bx, by = mirrored_b(theta2)
    t3, t4 = math.atan2(by - ay, bx - ax), math.atan2(by, bx - GROUND)
    return math.remainder(t4 - t3, 2 * math.pi)


def test_an_any_mode_target_is_replayed_as_the_node_answers_it(tmp_path, scene, capsys):
    target = joint_b(0.2)
    msgs = [
        ('/cmd', 1_000, joint_state(['crank'], [0.3], 1, 0)),
        ('/target', 2_000, joint_state(['B'], [target], 2, 0)),  # refused: the other circuit
        ('/any', 3_000, joint_state(['B'], [target], 3, 0)),  # answered there
        ('/cmd', 4_000, joint_state(['crank'], [0.5], 4, 0)),  # on that circuit from then on
    ]
    src = tmp_path / 'in'
    write_bag(src, 'mcap', msgs)
    out_csv, out_bag = tmp_path / 'out.csv', tmp_path / 'out_bag'
    code, out = run_bag(
        [src, '--scene', scene, '--command-topic', '/cmd', '--target-topic', '/target',
         '--target-any-mode-topic', '/any', '--out', out_csv, '--out', out_bag, '--no-progress'],
        capsys,
    )  # fmt: skip
    assert code == 0, out.err
    rows = read_csv(out_csv)
    assert [r['topic'] for r in rows] == ['/cmd', '/target', '/any', '/cmd']
    assert [r['status'] for r in rows] == ['ok', 'error', 'ok', 'ok']
    assert 'reachable only in' in rows[1]['reason']
    assert abs(float(rows[2]['joint.B']) - target) < 1e-9
    bx, by = mirrored_b(0.5)
    assert abs(float(rows[3]['B.x']) - bx) < 1e-12 and abs(float(rows[3]['B.y']) - by) < 1e-12
    statuses = [m for _, m in read_out_bag(out_bag)[0]['/linkage_node/status']]
    kv = [{v.key: v.value for v in s.values} for s in statuses]
    assert [k['request'] for k in kv] == ['command', 'target', 'target_any_mode', 'command']
    assert kv[2]['mode_change'].startswith('+ -> -'), kv[2]
    assert list(kv[2])[-2:] == ['mode_change', 'request']  # (the node's order)
    assert 'mode_change' not in kv[3]


def test_the_any_mode_topic_must_differ_from_the_others(tmp_path, scene, capsys):
    src = tmp_path / 'in'
    write_bag(src, 'mcap', [('/cmd', 1_000, joint_state(['crank'], [0.3], 1, 0))])
    code, out = run_bag(
        [src, '--scene', scene, '--command-topic', '/cmd', '--target-any-mode-topic', '/cmd',
         '--out', tmp_path / 'o.csv'],
        capsys,
    )  # fmt: skip
    assert code == 2
    assert '--command-topic and --target-any-mode-topic must be different topics' in out.err
