"""The configurations of a batched Newton solve read off its unknowns: complex poses of every
link and every point's world position, in one pass each (solve_batch's Newton path)."""

from __future__ import annotations

import numpy as np

from ..execute import LinkPoses
from ..ops import CArray
from .compiled import CompiledSolve


def newton_poses(c: CompiledSolve, x: np.ndarray) -> tuple[LinkPoses, dict[str, CArray]]:
    """Complex poses of every link and every point's world position (read off the first link
    that carries it) from newton unknowns x (n, 3 per moving link: phi and the world position
    of the link's reference centroid o, so T = c - R(phi) o); the ground at rest. Every link
    and point in one pass each (columns of one array), in the float operations of
    Poses.world and link_poses."""
    system, n, ground = c.system, x.shape[0], c.mech.ground
    table = system.batch.pose_table()
    phi = x[:, 0::3]
    cos, sin = np.cos(phi), np.sin(phi)
    ox, oy = table.centroids
    Tx = x[:, 1::3] - (cos * ox - sin * oy)
    Ty = x[:, 2::3] - (sin * ox + cos * oy)
    zero = np.zeros(n)
    poses = LinkPoses()
    poses.set(ground, zero, CArray(zero, zero), CArray(np.ones(n), zero))
    for l, i in system.index.items():
        poses.set(l, phi[:, i], CArray(Tx[:, i], Ty[:, i]), CArray(cos[:, i], sin[:, i]))
    # a column per point: its owner's slot (the ground's last: at rest)
    cos_g = np.concatenate([cos, np.ones((n, 1))], axis=1)[:, table.owner]
    sin_g = np.concatenate([sin, zero[:, None]], axis=1)[:, table.owner]
    px, py = table.points
    re = (cos_g * px - sin_g * py) + np.concatenate([Tx, zero[:, None]], axis=1)[:, table.owner]
    im = (sin_g * px + cos_g * py) + np.concatenate([Ty, zero[:, None]], axis=1)[:, table.owner]
    pts = {p: CArray(re[:, j], im[:, j]) for j, p in enumerate(table.names)}
    return poses, pts
