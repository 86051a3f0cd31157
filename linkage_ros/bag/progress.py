"""Progress bar (tqdm) and the closing summary on stderr."""

from __future__ import annotations

import re
import sys
from collections import Counter

import numpy as np
from tqdm import tqdm

from ..cli.process import say
from .common import OutputKind

# ---- progress and summary ----------------------------------------------------------------------


class Progress:
    """A tqdm progress bar on stderr, one phase at a time (reading, solving, writing); only when
    enabled (stderr is a terminal and --no-progress was not given)."""

    def __init__(self, enabled: bool, position: int | None = None, prefix: str = ''):
        """``position``: the terminal line (0 the first) where several bars show at once (a
        fleet's per-bag bars below its own); ``prefix``: what the bar's label starts with."""
        self.enabled = enabled
        self.position, self.prefix = position, prefix
        self.bar: tqdm | None = None

    def start(self, label: str, total: int) -> None:
        self.clear()
        if self.enabled:
            # file is looked up now, not at import: tests and callers may have replaced stderr
            self.bar = tqdm(
                total=max(int(total), 0),
                desc=f'{self.prefix}{label:<8}',
                file=sys.stderr,
                leave=False,
                mininterval=0.1,
                dynamic_ncols=True,
                position=self.position,
            )

    def update(self, done: int) -> None:
        """Move the bar to ``done`` items of the phase's total."""
        if self.bar is not None:
            self.bar.update(max(int(done) - self.bar.n, 0))

    def finish(self) -> None:
        if self.bar is not None:
            self.bar.update(self.bar.total - self.bar.n)
            self.bar.refresh()

    def clear(self) -> None:
        """Take the bar off the line, so what is printed next starts on a line of its own."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


_NUM = re.compile(r'(?<![A-Za-z_0-9.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?')


def _reason_class(reason: str) -> str:
    """A reason with its numbers blanked, so refusals of one kind count together (the
    summary shows each kind by its first refusal, numbers and all)."""
    return _NUM.sub('#', reason)


def summary_text(data, res, outs, plot, t0, t_read, t_solve, t_end):
    n = data.n
    lines = [
        f'linkage bag: {n + data.skipped} message(s) read from {data.source}'
        + (
            f" ({data.skipped} without the mechanism's inputs skipped: --state-completion)"
            if data.skipped
            else ''
        )
    ]
    for k, topic in enumerate(data.topics):
        lost = data.missing.get(topic)
        # (only the command topic's messages are skipped: state_completion)
        skipped = data.skipped if k == 0 else 0
        read = int(np.count_nonzero(data.topic == k)) + skipped
        lines.append(
            f'  {topic}: {read}'
            + (f' ({skipped} skipped)' if skipped else '')
            + (
                f' (MISSING {lost} of the {read + lost} the bag counts: --accept-missing)'
                if lost
                else ''
            )
        )
    if not n + data.skipped:  # (a wrong topic reads as an empty bag: say so)
        lines.append('  nothing to solve: no message on the topics given (the right topic?)')
    solved = int(np.count_nonzero(res.ok))
    lines.append(f'  solved {solved}, refused {n - solved}')
    counts: Counter[str] = Counter()
    example: dict[str, str] = {}  # each kind's first refusal, as the rows say it
    varied: set[str] = set()  # the kinds whose refusals differ in their numbers
    for r, ok in zip(res.reason, res.ok):
        if not ok:
            cls = _reason_class(r)
            counts[cls] += 1
            if example.setdefault(cls, r) != r:
                varied.add(cls)
    for cls, c in counts.most_common(8):
        lines.append(f'    {c} x {"e.g. " if cls in varied else ""}{example[cls]}')
    if len(counts) > 8:
        lines.append(f'    ... and {len(counts) - 8} other kind(s) of refusal')
    # (rows refused from the message alone reach no solver: a NaN value or velocity, an
    # unknown name, a bad stamp or shape)
    unsolved = n - res.batched - res.sequential
    lines.append(
        f'  vectorised rows {res.batched}, one-by-one rows {res.sequential}'
        + (f', refused before any solve {unsolved}' if unsolved else '')
    )
    for kind, path in outs:
        lines.append(f'  wrote {path} ({"csv" if kind is OutputKind.CSV else "rosbag2"})')
    if plot:
        lines.append(f'  wrote {plot} (plot)')
    total = t_end - t0
    lines.append(
        f'  time {total:.2f} s (read {t_read - t0:.2f}, solve {t_solve - t_read:.2f}, '
        f'write {t_end - t_solve:.2f})'
        + (f', {n / total:,.0f} commands/s' if total > 0 and n else '')
    )
    say('\n'.join(lines))
