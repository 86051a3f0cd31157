"""Progress bar (tqdm) and the closing summary on stderr."""

from __future__ import annotations

import re
import sys
import time
from collections import Counter

import numpy as np

# ---- progress and summary ----------------------------------------------------------------------


class _Progress:
    """A one-line text progress bar on stderr (only when it is a terminal)."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.label, self.total, self.t0, self.last = '', 0, 0.0, 0.0
        self.shown = False

    def start(self, label: str, total: int):
        self.label, self.total = label, max(int(total), 0)
        self.t0 = self.last = time.perf_counter()
        self.update(0, force=True)

    def update(self, done: int, force: bool = False):
        if not self.enabled:
            return
        now = time.perf_counter()
        if not force and now - self.last < 0.1:
            return
        self.last = now
        width = 30
        frac = min(done / self.total, 1.0) if self.total else 1.0
        bar = '#' * int(frac * width) + '-' * (width - int(frac * width))
        sys.stderr.write(
            f'\r{self.label:<8} [{bar}] {100 * frac:5.1f}% {done}/{self.total} '
            f'{now - self.t0:6.1f}s'
        )
        sys.stderr.flush()
        self.shown = True

    def finish(self):
        if self.enabled:
            self.update(self.total, force=True)

    def clear(self):
        if self.enabled and self.shown:
            sys.stderr.write('\r' + ' ' * 79 + '\r')
            sys.stderr.flush()
            self.shown = False


_NUM = re.compile(r'(?<![A-Za-z_0-9.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?')


def _reason_class(reason: str) -> str:
    """A reason with its numbers blanked, so refusals of one kind count together."""
    return _NUM.sub('#', reason)


def _summary(data, res, outs, plot, t0, t_read, t_solve, t_end):
    n = data.n
    lines = [f'linkage bag: {n} message(s) read from {data.source}']
    for k, topic in enumerate(data.topics):
        lines.append(f'  {topic}: {int(np.count_nonzero(data.topic == k))}')
    solved = int(np.count_nonzero(res.ok))
    lines.append(f'  solved {solved}, refused {n - solved}')
    counts = Counter(_reason_class(r) for r, ok in zip(res.reason, res.ok) if not ok)
    for cls, c in counts.most_common(8):
        lines.append(f'    {c} x {cls}')
    if len(counts) > 8:
        lines.append(f'    ... and {len(counts) - 8} other kind(s) of refusal')
    lines.append(f'  vectorised rows {res.batched}, one-by-one rows {res.sequential}')
    for kind, path in outs:
        lines.append(f'  wrote {path} ({"csv" if kind == "csv" else "rosbag2"})')
    if plot:
        lines.append(f'  wrote {plot} (plot)')
    total = t_end - t0
    lines.append(
        f'  time {total:.2f} s (read {t_read - t0:.2f}, solve {t_solve - t_read:.2f}, '
        f'write {t_end - t_solve:.2f})'
        + (f', {n / total:,.0f} commands/s' if total > 0 and n else '')
    )
    print('\n'.join(lines))
