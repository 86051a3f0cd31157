"""How every linkage command ends: its exit status whatever becomes of stdout (a reader that
stopped, a full disk, a stream closed before the start), Ctrl-C and SIGTERM in the shell's
convention (cli.common has the commands' shared parsing and loading)."""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import signal
import sys
from collections.abc import Iterator
from typing import Any

from ..core.errors import LinkageError
from .common import OK, USAGE_ERROR, UsageError

INTERRUPTED = 130  # Ctrl-C, as a shell reports a SIGINT
TERMINATED = 143  # SIGTERM, as a shell reports it


class Terminated(BaseException):
    """A SIGTERM a command turned into an exception to end its own way (terminate_raises):
    a fleet stops its worker processes first (a kill of the parent alone left them idle)."""


def stdout_gone() -> None:
    """The reader of stdout has stopped (`| head`, `| true`): what is still written goes to
    os.devnull (Python's advice for SIGPIPE: the flush at exit then has nowhere to fail), so
    the command ends its work and exits with its own status."""
    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # (not a file: replace the object)
        sys.stdout = open(os.devnull, 'w')  # noqa: SIM115 (lives as long as the process)
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, fd)
    os.close(devnull)


def say(text: str = '') -> None:
    """print(text) on stdout: a reader that has stopped ends the printing, not the command
    (a summary nobody reads changes no outcome)."""
    try:
        print(text)
    except BrokenPipeError:
        stdout_gone()


#: write errors of a standard output that cannot take more (a full disk, a quota, /dev/full)
_STDOUT_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO)


def run_command(prog: str, func: Any, args: argparse.Namespace) -> int:
    """``func(args)``'s exit status, as every command (``linkage X`` and ``python -m``'s
    stand-alone entry points) ends: a usage or linkage error one line on stderr (2), Ctrl-C
    the shell's 130, stdout's write errors said (a full disk) or, where its reader stopped
    (`| head`), the command's own status (what it printed through say went to os.devnull).
    A stream closed before the start (`>&-`: Python's sys.stdout is None) is os.devnull too."""
    for name in ('stdout', 'stderr'):
        if getattr(sys, name) is None:
            setattr(sys, name, open(os.devnull, 'w'))  # noqa: SIM115 (lives as long as the process)
    try:
        code = int(func(args))
        try:
            sys.stdout.flush()  # (here: a write error is this command's, not the interpreter's)
        except BrokenPipeError:  # `linkage bag ... | true`: the work is done, its status stands
            stdout_gone()
        return code
    except (UsageError, LinkageError) as exc:
        print(f'{prog}: error: {exc}', file=sys.stderr)
        return USAGE_ERROR
    except BrokenPipeError:  # a stream whose reader stopped (`linkage echo ... | head`): done
        stdout_gone()
        return OK
    except OSError as exc:
        if exc.errno not in _STDOUT_FULL:
            raise
        # stdout on a full disk (or /dev/full): the files a command writes say so themselves
        print(f'{prog}: error: cannot write standard output: {exc.strerror}', file=sys.stderr)
        stdout_gone()
        return USAGE_ERROR
    except KeyboardInterrupt:  # Ctrl-C: the shell's convention, no traceback
        print(f'\n{prog}: interrupted', file=sys.stderr)
        return INTERRUPTED
    except Terminated:
        print(f'{prog}: terminated', file=sys.stderr)
        return TERMINATED


@contextlib.contextmanager
def terminate_raises() -> Iterator[None]:
    """Within: a SIGTERM raises Terminated in the main thread (the handler before restored on
    leaving). Install it after forking workers: a forked child inherits Python's handlers."""

    def raise_terminated(signum: int, frame: Any) -> None:
        raise Terminated

    before = signal.signal(signal.SIGTERM, raise_terminated)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)
