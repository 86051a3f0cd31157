"""Readers of robot descriptions (URDF, URDF+ ``<loop>``, the urdfdom ``<constraint>``
proposal, SDFormat, Gepetto's YAML and the linkage_ros closure file) -> one closure record ->
the chain in its plane -> an assembled scene and the map of the description's own joint
coordinates. See docs/ROBOT_DESCRIPTIONS.md."""

from __future__ import annotations

from ..model.joint_map import JointMap
from .importer import Imported, import_description, is_description, read_description
from .records import DescriptionError

__all__ = [
    'DescriptionError',
    'Imported',
    'JointMap',
    'import_description',
    'is_description',
    'read_description',
]
