"""One way in for every front end: a scene file, or a robot description (URDF/SDF file or
text) with its optional closure side file, -> a Scene."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from .description import import_description, is_description
from .errors import SceneError
from .model import Scene


def load_scene(
    scene: str,
    dimensions: Mapping[str, float] | None = None,
    closures: str | None = None,
    actuated: Sequence[str] | None = None,
    text: bool = False,
) -> Scene:
    """``scene``: a scene file path, a description path (.urdf, .sdf, .xml) or, with ``text``,
    a description's XML text (robot_description). ``closures``: a closure side file (a
    linkage_ros closure file or Gepetto's YAML); ``actuated``: the description's actuated
    joints where it does not mark them. Dimensions override stated lengths by name."""
    if text or is_description(scene):
        imported = import_description(scene, closures, actuated, dimensions=dimensions, text=text)
        return Scene(imported.mechanism, None if text else scene, imported.notes)
    if closures or actuated:
        what = 'closures' if closures else 'actuated'
        raise SceneError(
            f'{what} applies to a robot description (.urdf, .sdf); a scene file states its '
            'closures and actuators itself',
            file=scene,
        )
    return Scene.from_yaml(scene, dimensions)
