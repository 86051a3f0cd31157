"""Where the packaged scene files live (colcon install share/ or the source tree)."""

from __future__ import annotations

from pathlib import Path


def config_dir() -> Path:
    """The directory of the packaged scene files (config/)."""
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

        try:
            share = Path(get_package_share_directory('linkage_ros')) / 'config'
            if share.is_dir():
                return share
        except (PackageNotFoundError, OSError):  # OSError: AMENT_PREFIX_PATH unset
            pass
    except ImportError:  # no ROS on this machine: the source tree is the package
        pass
    return Path(__file__).resolve().parent.parent / 'config'


def scene_path(name: str) -> Path:
    """Resolve a scene argument: an existing path, else a packaged scene by file or stem name."""
    p = Path(name)
    if p.exists():
        return p
    cand = config_dir() / (name if name.endswith('.yaml') else name + '.yaml')
    return cand if cand.exists() else p


def default_scene() -> Path:
    return config_dir() / 'four_bar.yaml'
