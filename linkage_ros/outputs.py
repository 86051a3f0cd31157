"""Writing an output file whole or not at all (the CLI, the bag tool and the bench alike).

A write that fails half-way (a full disk, ``ulimit -f``, an interrupt) must not leave a cut file
under the target's name that looks like a result: every output is written to a temporary file
beside the target and renamed into place (atomic on POSIX) only once it is complete; on any
failure the temporary file is removed and the target is left as it was.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def written_whole(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield the temporary path to write; on success it replaces ``path``, on an exception
    (also KeyboardInterrupt) it is removed and the exception goes on."""
    target = Path(path)
    tmp = target.with_name(f'.{target.name}.{os.getpid()}.partial')
    try:
        yield tmp
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def folder_refusal(path: str | os.PathLike[str]) -> str | None:
    """Why the folder of ``path`` cannot take a new file ('folder F does not exist', ... is not
    a folder, ... is not writable), or None: checked before any work, so a run is not lost
    at its end (the CLI's --csv, the bag tool's outputs)."""
    parent = Path(path).parent
    if not parent.is_dir():
        return f'folder {parent} ' + ('is not a folder' if parent.exists() else 'does not exist')
    if not os.access(parent, os.W_OK | os.X_OK):
        return f'folder {parent} is not writable (permission denied)'
    return None
