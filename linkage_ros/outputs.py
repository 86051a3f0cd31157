"""Writing an output file whole or not at all (the CLI, the bag tool and the bench alike).

A write that fails half-way (a full disk, ``ulimit -f``, an interrupt) must not leave a cut file
under the target's name that looks like a result: every output is written to a temporary file
beside the target and renamed into place (atomic on POSIX) only once it is complete; on any
failure the temporary file is removed and the target is left as it was. A target that is a
symlink is followed (the file it names is written whole, the link kept); one that is no regular
file (``/dev/stdout``, a FIFO a reader waits on, ``/dev/null``) is written in place, as a shell's
redirection writes it: renaming a file onto it replaced the device or the pipe itself.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
from collections.abc import Iterable, Iterator
from pathlib import Path


@contextlib.contextmanager
def written_whole(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield the temporary path to write; on success it replaces ``path``, on an exception
    (also KeyboardInterrupt) it is removed and the exception goes on. A folder at ``path`` is
    IsADirectoryError; a device, FIFO or socket is yielded itself (written in place)."""
    given = Path(path)
    loop = _link_loop(given)
    if loop:
        raise OSError(errno.ELOOP, loop, str(path))
    if given.exists() and not given.is_file():  # (stat follows a symlink)
        if given.is_dir():
            raise IsADirectoryError(errno.EISDIR, 'is a folder', str(path))
        yield given
        return
    target = Path(os.path.realpath(given)) if given.is_symlink() else given
    tmp = target.with_name(staging_name(target.name))
    try:
        yield tmp
        if target.exists():  # (the file replaced keeps its permissions: a 600 file stays so)
            shutil.copymode(target, tmp)
        os.replace(tmp, target)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def staging_name(name: str) -> str:
    """The hidden name a file is written under beside its target until it is whole."""
    return f'.{name}.{os.getpid()}.partial'


#: what staging_name adds to a name at most (a pid has at most 7 digits: pid_max 4194304)
STAGING_EXTRA = len(staging_name('')) - len(str(os.getpid())) + 7


def _link_loop(path: Path) -> str | None:
    """'is a symlink loop' where ``path`` is one (a shell's redirection reports ELOOP; replacing
    the link with a file hid it: an adversary), else None."""
    if not path.is_symlink():
        return None
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return 'is a symlink loop'
    return None


def folder_refusal(path: str | os.PathLike[str]) -> str | None:
    """Why the folder of ``path`` cannot take a new file ('folder F does not exist', ... is not
    a folder, ... is not writable), or None: checked before any work, so a run is not lost
    at its end (the CLI's --csv, the bag tool's outputs). A folder at ``path`` itself is
    refused; a device or FIFO there is written in place (written_whole), its folder aside."""
    too_long = name_refusal(path)
    if too_long:
        return too_long
    given = Path(path)
    loop = _link_loop(given)
    if loop:
        return f'{path} {loop}'
    if given.is_dir():
        return f'{path} is a folder'
    if given.exists() and not given.is_file():
        return None if os.access(given, os.W_OK) else f'{path} is not writable (permission denied)'
    if given.is_symlink():
        given = Path(os.path.realpath(given))
    parent = given.parent
    if not parent.is_dir():
        return f'folder {parent} ' + ('is not a folder' if parent.exists() else 'does not exist')
    if not os.access(parent, os.W_OK | os.X_OK):
        return f'folder {parent} is not writable (permission denied)'
    return None


def input_refusal(
    path: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]]
) -> str | None:
    """Why ``path`` cannot be written: it is one of the command's ``inputs`` (the scene file
    named again by --csv or -o was replaced by the output: an adversary); None otherwise."""
    for given in inputs:
        with contextlib.suppress(OSError):
            if os.path.samefile(path, given):
                return f'is the input {given} (writing it would replace it)'
    return None


#: a file name's longest part where the file system does not say (Linux's NAME_MAX)
NAME_MAX = 255


def name_refusal(path: str | os.PathLike[str]) -> str | None:
    """Why ``path`` cannot name a file on its file system: a part longer than it takes (a
    246-character --out gave a 'File name too long' traceback naming the trajectories' CSV
    beside it, and one long bag name ended a whole fleet: an adversary); None otherwise."""
    full = Path(os.path.abspath(path))
    probe = full
    while not os.path.exists(probe) and probe != probe.parent:  # (os.path: no OSError)
        probe = probe.parent
    try:
        limit = os.pathconf(probe, 'PC_NAME_MAX')
    except (OSError, ValueError):
        limit = NAME_MAX
    for k, part in enumerate(full.parts):
        size = len(os.fsencode(part))
        # (the last part is written under its staging name first: that one must fit too)
        room = limit - STAGING_EXTRA if k == len(full.parts) - 1 else limit
        if size > room:
            return (
                f'its name {part[:24]}...{part[-12:]} is {size} bytes, beyond the {room} its '
                f'file system takes'
                + (' with the staging name written first' if room < limit else '')
            )
    return None


#: how a spreadsheet tells a formula from text at a cell's start (OWASP's CSV-injection list)
FORMULA_STARTS = ('=', '+', '-', '@', '\t', '\r')


def text_cell(text: str) -> str:
    """A CSV text cell (a bag's or topic's name, a reason) as a spreadsheet shows it: one that
    starts as a formula would (`=cmd|calc`, `@SUM(A1)`, `-2+3`) gets a leading single quote,
    OWASP's advice (an adversary's bag names and topics reached summary.csv as formulas).
    Numbers are not text cells; JSON and Parquet keep every text as it is."""
    return "'" + text if text.startswith(FORMULA_STARTS) else text
