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
