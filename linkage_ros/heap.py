"""Keep large buffers in the process (glibc malloc thresholds): the node's message copies, and
the arrays of batch solves (the ``linkage`` command line raises them at its start too).

Every request is copied twice on the command thread when rclpy takes it serialised (into rmw's
buffer, then into Python bytes), before the node can refuse it by its size. glibc serves a
buffer of MBs from the top of its heap and gives it back to the kernel once more than its trim
threshold (by default twice the largest buffer freed so far) is free there: with two buffers of
one 2 MB ~/target freed together, that is after every message, and the next message faults
every page in again. Measured with the node alone beside a 100 Hz flood of 2 MB ~/target
requests (10^5 names): 250k-380k page faults and 1.0-1.5 s of the command thread's CPU in 4 s
(about 5.8 ms per message taken) with glibc's defaults; 16-3200 faults and 0.34-0.37 s (about
1.1 ms per message, the copies) with the thresholds below. The same holds for a batch solve's
arrays: a 20000-row four-bar batch makes (20000,) columns of 160 kB, above glibc's default
mmap threshold, and faulted about 500 pages in per batch, 25 % of its time (246-260 against
193-194 ns per input, one process each, quiet 2-core host).
"""

from __future__ import annotations

import ctypes
import os
import platform
from collections.abc import Mapping

#: buffers up to this size come from the heap (and are reused) rather than from mmap
MMAP_THRESHOLD_BYTES = 16 << 20
#: free memory at the top of the heap kept for the next buffers, not given back to the kernel
TRIM_THRESHOLD_BYTES = 32 << 20
#: mallopt parameters (glibc's malloc.h)
_M_TRIM_THRESHOLD = -1
_M_MMAP_THRESHOLD = -3
#: the settings of a user who tuned glibc's malloc themselves: then it is left as they set it
_USER_SETTINGS = ('MALLOC_MMAP_THRESHOLD_', 'MALLOC_TRIM_THRESHOLD_', 'MALLOC_TOP_PAD_')


def keep_large_buffers(environ: Mapping[str, str] = os.environ) -> bool:
    """Raise glibc's mmap and trim thresholds for this process (MMAP_THRESHOLD_BYTES,
    TRIM_THRESHOLD_BYTES). Nothing is changed where the C library is not glibc or the user set
    malloc's thresholds (MALLOC_*_ variables, GLIBC_TUNABLES glibc.malloc.*). True when
    applied."""
    if any(name in environ for name in _USER_SETTINGS):
        return False
    if 'glibc.malloc.' in environ.get('GLIBC_TUNABLES', ''):
        return False
    return set_malloc_thresholds(MMAP_THRESHOLD_BYTES, TRIM_THRESHOLD_BYTES)


def set_malloc_thresholds(mmap_bytes: int, trim_bytes: int) -> bool:
    """Set glibc malloc's mmap threshold (buffers up to it come from the heap) and trim
    threshold (free memory kept at the top of the heap) for this process, in bytes. True when
    set; False, changing nothing, where the C library is not glibc."""
    if platform.libc_ver()[0] != 'glibc':
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    # the mmap threshold first: setting either one ends glibc's own adjustment of both
    return bool(mallopt(_M_MMAP_THRESHOLD, mmap_bytes) and mallopt(_M_TRIM_THRESHOLD, trim_bytes))
