"""Link poses over a batch as (n, 2) coordinates, and the views between them and complex poses."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import dyads
from ..execute import LinkPoses, PlanRun
from ..model import Mechanism
from ..ops import BATCH, to_complex, to_xy

# ---- poses -----------------------------------------------------------------------------------


@dataclass
class Poses:
    """Link poses over a batch: world(p) = R(phi) p_ref + T, with p_ref the reference position."""

    phi: dict[str, np.ndarray] = field(default_factory=dict)
    T: dict[str, np.ndarray] = field(default_factory=dict)

    def apply(self, link: str, p_ref: np.ndarray) -> np.ndarray:
        world: np.ndarray = (
            dyads.rotate(np.broadcast_to(p_ref, self.T[link].shape), self.phi[link]) + self.T[link]
        )
        return world

    def world(self, link: str, point: str, mech: Mechanism) -> np.ndarray:
        return self.apply(link, mech.points[point])


def batch_poses(poses: LinkPoses) -> Poses:
    """(n, 2)-coordinate view of batched complex link poses."""
    return Poses(dict(poses.phi), {l: to_xy(T) for l, T in poses.T.items()})


def link_poses(poses: Poses) -> LinkPoses:
    """Complex view of (n, 2)-coordinate batched link poses."""
    out = LinkPoses()
    for l, phi in poses.phi.items():
        out.set(l, phi, to_complex(poses.T[l]), BATCH.expi(phi))
    return out


ScalarPoses = LinkPoses


def reference_poses(mech: Mechanism) -> LinkPoses:
    """Every link where the scene draws it (angle 0, no translation): the reference pose."""
    ref = LinkPoses()
    for l in mech.links:
        ref.set(l, 0.0, 0j, 1 + 0j)
    return ref


ScalarRun = PlanRun
