"""Scene helpers shared by the tests (imported as ``scenes``; conftest.py makes the same
available as fixtures): where the repository and its scenes are, loading a shipped scene, and
building the shortcut mechanisms from lengths."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from linkage_ros.core.model import Mechanism, Scene

REPO = Path(__file__).resolve().parent.parent
CONFIG = REPO / 'config'


def load(stem: str) -> Mechanism:
    """The mechanism of a shipped scene (config/<stem>.yaml)."""
    return Scene.from_yaml(CONFIG / f'{stem}.yaml').mechanism


def raw(stem: str) -> Any:
    """A shipped scene file's YAML, as data."""
    with open(CONFIG / f'{stem}.yaml', encoding='utf-8') as fh:
        return yaml.safe_load(fh)


def four_bar(*lengths: Any, **extra: Any) -> Mechanism:
    """The four_bar shortcut from (ground, crank, coupler, rocker): four numbers or one tuple of
    them; ``extra`` keys go into the shortcut (coupler_point, ground_angle, branch, ...)."""
    if len(lengths) == 1:
        lengths = tuple(lengths[0])
    spec = dict(zip(('ground', 'crank', 'coupler', 'rocker'), lengths))
    spec.update(extra)
    return Scene.from_dict({'four_bar': spec}).mechanism


def slider_crank(r: float, rod: float, e: float = 0.0, direction: float = 0.0, **extra: Any):
    """The slider_crank shortcut from crank, rod, offset and stroke direction."""
    spec = {'crank': r, 'rod': rod, 'offset': e, 'direction': direction}
    spec.update(extra)
    return Scene.from_dict({'slider_crank': spec}).mechanism
