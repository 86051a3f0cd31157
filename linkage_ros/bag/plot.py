"""The input/output plot of a replay."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..core.model import AngleActuator
from ..outputs import written_whole
from .common import BagError
from .reading import Commands, exc_text
from .results import Results

# ---- plot --------------------------------------------------------------------------------------


def isolated_rows(ok: np.ndarray) -> np.ndarray:
    """The ok samples without an ok neighbour: a line broken at the refused rows (NaN) has no
    segment through them, so they need a marker of their own."""
    prev = np.concatenate(([False], ok[:-1]))
    after = np.concatenate((ok[1:], [False]))
    return ok & ~prev & ~after


def _broken_at_wraps(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An angle series (rad) with a gap (a NaN point) wherever two neighbouring samples differ
    by more than pi: a wrap at +-pi, drawn as a break, not as a full-height jump."""
    with np.errstate(invalid='ignore'):
        jump = np.flatnonzero(np.abs(np.diff(y)) > np.pi)
    if not jump.size:
        return x, y
    mid = 0.5 * (x[jump] + x[jump + 1])
    return np.insert(x, jump + 1, mid), np.insert(y, jump + 1, np.nan)


def _series(ax, x, y, ok, angle: bool = False, **style):
    """A line with gaps where not ok (and, for an angle, at its wraps), plus a dot for every
    ok sample the line cannot show."""
    xs, ys = np.asarray(x, float), np.where(ok, y, np.nan)
    if angle:
        xs, ys = _broken_at_wraps(xs, ys)
    (line,) = ax.plot(xs, ys, **style)
    lone = isolated_rows(ok)
    if lone.any():
        ax.plot(x[lone], y[lone], '.', ms=6, color=line.get_color())


def plot_figure(data: Commands, res: Results, mech, max_points: int = 20000):
    """The matplotlib figure of :func:`write_plot` (the caller closes it)."""
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    n = data.n
    step = max(1, n // max_points)
    idx = np.arange(0, n, step)
    t = (data.log_ns[idx] - (data.log_ns[0] if n else 0)) * 1e-9
    ok = res.ok[idx]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 5.5))
    outs = list(mech.outputs) or [p for p in mech.points][-1:]
    for p in outs:
        xy = res.points[p][idx]
        _series(ax1, xy[:, 0], xy[:, 1], ok, ls='-', lw=1.0, label=p)
    ax1.set_aspect('equal', adjustable='datalim')
    ax1.set_xlabel('x (m)')
    ax1.set_ylabel('y (m)')
    ax1.set_title(f'{mech.name}: coupler point trace' + ('s' if len(outs) > 1 else ''))
    if outs:
        ax1.legend(loc='best', fontsize='small')
    ax1.grid(True, alpha=0.3)
    # every angle drawn alike: wrapped to +-pi as the node gives joints (an input as commanded
    # may be any number of turns), each line broken where it wraps
    for a, act in mech.actuators.items():
        angle = isinstance(act, AngleActuator)
        y = res.inputs[a][idx]
        if angle:
            with np.errstate(invalid='ignore'):  # (a refused +-inf command: a gap anyway)
                y = np.arctan2(np.sin(y), np.cos(y))
        _series(ax2, t, y, ok, angle, lw=1.6, label=f'input {a}')
    for j in mech.joint_names:
        _series(
            ax2, t, res.joints[j][idx], ok, j not in mech.prismatics, lw=0.9, label=f'joint {j}'
        )
    bad = ~ok
    if np.any(bad):
        # marks on the time axis (axes coordinates), not values at y = 0
        ax2.plot(
            t[bad],
            np.zeros(int(bad.sum())),
            '|',
            color='red',
            ms=10,
            mew=1.5,
            transform=ax2.get_xaxis_transform(),
            clip_on=False,
            label='refused',
        )
    ax2.set_xlabel('bag time (s)')
    ax2.set_ylabel('rad / m')
    ax2.set_title('inputs and joints')
    ax2.legend(loc='best', fontsize='small', ncol=2)
    ax2.grid(True, alpha=0.3)
    fig.tight_layout()
    return fig


def write_plot(path: str, data: Commands, res: Results, mech, max_points: int = 20000):
    """Coupler-point traces (x-y) and inputs/joints against time (refused rows are gaps and
    red marks on the time axis; an accepted row between two refused ones is a dot; an angle's
    line is broken where it wraps at +-pi)."""
    import matplotlib.pyplot as plt

    fmt = plot_format(str(path))  # the file named is the file written (no '.png' added)
    fig = plot_figure(data, res, mech, max_points)
    try:
        with written_whole(path) as tmp:
            fig.savefig(tmp, dpi=110, format=fmt)
    except OSError as exc:
        raise BagError(f'--plot {path}: {exc.strerror or exc}') from None
    except Exception as exc:  # noqa: BLE001 - e.g. a format whose writer is missing (pgf: LaTeX)
        raise BagError(f'--plot {path}: cannot write the image ({exc_text(exc)})') from None
    finally:
        plt.close(fig)


def plot_formats() -> list[str]:
    """The image formats (file extensions) matplotlib can write."""
    from matplotlib.backend_bases import FigureCanvasBase

    return sorted(FigureCanvasBase.get_supported_filetypes())


def plot_format(path: str) -> str:
    """The image format of a --plot path: its extension, or PNG for a name without one."""
    ext = Path(path).suffix.lower().lstrip('.')
    if not ext:
        return 'png'
    formats = plot_formats()
    if ext not in formats:
        raise BagError(
            f'--plot {path}: cannot write a .{ext} image (image formats: {", ".join(formats)})'
        )
    return ext
