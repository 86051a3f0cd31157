"""Writing the results as CSV (exact shortest float text, vectorised)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..outputs import text_cell, written_whole
from .progress import Progress
from .reading import Commands
from .results import Results

# ---- writing: CSV ------------------------------------------------------------------------------
# Python formats a float in ~0.6 us; a million rows of twenty numbers is seconds of it. The text
# is built here with numpy instead: each column as an (n, width) byte array in which a zero byte
# means "nothing", the columns side by side, the zero bytes dropped.

_P10 = np.array([10.0**k for k in range(23)])  # exact doubles
_SPLIT = 134217729.0  # 2**27 + 1 (Veltkamp split)
_U4 = np.uint64(10000)
_LUT4 = np.array(
    [
        [48 + (k // 1000) % 10, 48 + (k // 100) % 10, 48 + (k // 10) % 10, 48 + k % 10]
        for k in range(10000)
    ],
    np.uint8,
)
_TZ4 = np.array(
    [
        4 if k == 0 else 3 if k % 1000 == 0 else 2 if k % 100 == 0 else 1 if k % 10 == 0 else 0
        for k in range(10000)
    ],
    np.int16,
)
_LUT4W = _LUT4.copy().view('<u4').ravel()  # the four digits as one word
_KEEPW = np.array([0, 0xFF, 0xFFFF, 0xFFFFFF, 0xFFFFFFFF], '<u4')  # keep the first k bytes
FLOAT_WIDTH = 44  # _repr_layout's columns (most are zero bytes: nothing)


def _two_prod(a, b):
    """a * b == p + e exactly (Dekker's error-free product)."""
    p = a * b
    t = a * _SPLIT
    ah = t - (t - a)
    al = a - ah
    t = b * _SPLIT
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _digits17(a):
    """For 1e-28 <= a < 1e16: the correctly rounded 17 significant digits D (uint64,
    1e16 <= D < 1e17), the decimal exponent e and the rest r (|r| <= 0.5), with
    a * 10**(16 - e) = D + r (to far better than the rest's size)."""
    e = np.floor(np.log10(a)).astype(np.int64)
    for _ in range(3):
        k = 16 - e
        k1 = np.minimum(k, 22)
        p, err = _two_prod(a, _P10[k1])
        k2 = k - k1
        if np.any(k2):  # tiny values: a second exact power of ten
            m = k2 > 0
            P2 = _P10[k2]
            p2, e2 = _two_prod(p, P2)
            err = np.where(m, e2 + err * P2, err)
            p = np.where(m, p2, p)
        whole = np.rint(err)
        D = p.astype(np.uint64) + whole.astype(np.int64).astype(np.uint64)
        hi = np.uint64(10**17) <= D
        lo = np.uint64(10**16) > D
        if not (hi.any() or lo.any()):
            break
        e = e + hi - lo  # log10 was off by one next to a power of ten
    # p >= 1e16 > 2**53 is a whole number: the rest is err's fraction
    return D, e, err - whole


def _round_trips(cand, D, rest, a) -> tuple[np.ndarray, np.ndarray]:
    """(parses back to a, cannot tell) for candidate digits ``cand`` on D's scale: the
    candidate is within half an ulp of a (a quarter below a power of two); a candidate too
    near that bound to tell from the rest's precision is left to repr()."""
    delta = (cand.astype(np.int64) - D.astype(np.int64)).astype(float) - rest
    half = 0.5 * np.spacing(a) / a * (D.astype(float) + rest)
    pow2 = (a.view(np.int64) & np.int64((1 << 52) - 1)) == 0
    half = np.where(pow2 & (delta < 0), 0.5 * half, half)
    unsure = np.abs(np.abs(delta) - half) <= 1e-6 * half
    return (np.abs(delta) < half) & ~unsure, unsure


def _exact_value(D, exp10):
    """D * 10**exp10 correctly rounded (as float() would parse it) where that is one exact
    operation (D < 2**53, |exp10| <= 22); NaN elsewhere."""
    ok = (np.abs(exp10) <= 22) & (np.uint64(2**53) > D)
    pe = _P10[np.minimum(np.abs(exp10), 22)]
    Df = D.astype(float)
    return np.where(ok, np.where(exp10 >= 0, Df * pe, Df / pe), np.nan)


def format_floats(values, nan: bytes = b'') -> np.ndarray:
    """Text of float64 values as an (n, FLOAT_WIDTH) uint8 array, zero bytes meaning nothing.

    Python's repr() of each value (``0.9479697413828935``, ``-1.2566383147671889e-05``,
    ``0.5``, ``2.0``): text that parses back to exactly the same double, in one format for every
    number: 17 correctly rounded significant digits, shortened to 15 or 16 where those provably
    round-trip, trailing zeros dropped, laid out as repr lays them out. Zero is ``0.0``, NaN
    ``nan`` (default: empty); infinities and extreme magnitudes go through repr() itself.
    """
    v = np.asarray(values, float).ravel()
    n = v.size
    bits = v.view(np.int64)
    if n > 1 and (bits == bits[0]).all():
        return np.broadcast_to(format_floats(v[:1], nan), (n, FLOAT_WIDTH))  # e.g. ground
    a = np.abs(v)
    with np.errstate(invalid='ignore'):
        regular = np.isfinite(v) & (a >= 1e-28) & (a < 1e16)
    allreg = bool(regular.all())
    if allreg:
        ar, m, vr = a, n, v
    else:
        idx = np.flatnonzero(regular)
        ar, m, vr = a[idx], idx.size, v[idx]
    rows = np.zeros((m, FLOAT_WIDTH), np.uint8)
    if m:
        D17, e, rest = _digits17(ar)
        D, unsure, done = D17, np.zeros(m, bool), np.zeros(m, bool)
        for drop in (2, 1):  # the shortest: 15 digits (or fewer), else 16, else 17
            q, r = np.divmod(D17, np.uint64(10**drop))
            # rounded from a's digits (D17 + rest), not from D17: no double rounding
            r = r.astype(float) + rest
            half = 5.0 * 10 ** (drop - 1)
            q = q + ((r > half) | ((r == half) & ((q & np.uint64(1)) == 1))).astype(np.uint64)
            cand = q * np.uint64(10**drop)
            good, unsure_here = _round_trips(cand, D17, rest, ar)
            good &= (q < np.uint64(10 ** (17 - drop))) & ~done
            unsure |= unsure_here & ~done
            D = np.where(good, cand, D)
            done |= good
        q, g4 = np.divmod(D, _U4)
        q, g3 = np.divmod(q, _U4)
        q, g2 = np.divmod(q, _U4)
        g0, g1 = np.divmod(q, _U4)
        tz = _TZ4[g4]  # trailing zeros, four digits at a time
        full = tz == 4
        for g in (g3, g2, g1):
            t = _TZ4[g]
            tz = tz + np.where(full, t, 0)
            full &= t == 4
        keep = 16 - tz  # significant digits after the first
        digits = np.concatenate(
            [
                (g0.astype(np.uint8) + np.uint8(48))[:, None],
                _LUT4[g1],
                _LUT4[g2],
                _LUT4[g3],
                _LUT4[g4],
            ],
            axis=1,
        )
        rows = _repr_layout(np.signbit(vr), digits, keep.astype(np.int64) + 1, e)
        for i in np.flatnonzero(unsure).tolist():  # a handful in a million
            b = repr(float(vr[i])).encode()
            rows[i] = 0
            rows[i, : len(b)] = np.frombuffer(b, np.uint8)
    if allreg:
        return rows
    out = np.zeros((n, FLOAT_WIDTH), np.uint8)
    out[idx] = rows
    zero = v == 0
    if zero.any():  # '0.0' / '-0.0'
        z = np.flatnonzero(zero)
        neg = np.signbit(v[z])
        out[z, 0] = neg * np.uint8(45)
        out[z, 1:4] = np.frombuffer(b'0.0', np.uint8)
    isnan = np.isnan(v)
    if isnan.any() and nan:
        out[np.flatnonzero(isnan), : len(nan)] = np.frombuffer(nan, np.uint8)
    for i in np.flatnonzero(~regular & ~zero & ~isnan).tolist():
        b = repr(float(v[i])).encode()
        out[i, : len(b)] = np.frombuffer(b, np.uint8)
    return out


_COL17 = np.arange(17)[None, :]


def _repr_layout(neg, digits, nd, e) -> np.ndarray:
    """Python's repr() of regular doubles (1e-28 <= |v| < 1e16) from their shortest
    round-trip digits (``digits``: (m, 17) ASCII, the first ``nd`` significant, the rest '0')
    and decimal exponent ``e``: fixed notation for 1e-4 <= |v| < 1e16 (``0.05403023058681398``,
    ``2.0``, ``0.0001``), else ``d.ddde-XX`` (``1e-05``, ``1.5e-07``).

    The bytes sit in fixed columns and a zero byte is nothing, so no row is shifted: sign,
    a '0.000' prefix (used for 1e-4 <= |v| < 1), each digit followed by a slot for the '.'
    (after digit e, or after the first digit in scientific notation), the 'e-XX' suffix.
    Returns (m, FLOAT_WIDTH) uint8."""
    m = digits.shape[0]
    e, nd = e[:, None], nd[:, None]
    fixed = e >= -4
    small = fixed & (e < 0)
    sci = ~fixed
    out = np.zeros((m, FLOAT_WIDTH), np.uint8)
    out[:, 0] = neg * np.uint8(45)  # '-'
    out[:, 1] = small[:, 0] * np.uint8(48)  # '0'
    out[:, 2] = small[:, 0] * np.uint8(46)  # '.'
    out[:, 3:6] = (small & (np.arange(3)[None, :] < -e - 1)) * np.uint8(48)  # leading zeros
    # digits: the significant ones; for |v| >= 1 the integer part and one fraction digit too
    keep = (nd > _COL17) | ((e >= 0) & (e + 1 >= _COL17))
    body = out[:, 6:40].reshape(m, 17, 2)
    body[:, :, 0] = digits * keep
    dot = ((e >= 0) & (e == _COL17)) | (sci & (_COL17 == 0) & (nd > 1))
    body[:, :, 1] = dot * np.uint8(46)
    x = np.abs(e[:, 0])
    out[:, 40] = sci[:, 0] * np.uint8(101)  # 'e'
    out[:, 41] = sci[:, 0] * np.uint8(45)  # '-': |v| < 1e-4 here
    out[:, 42] = sci[:, 0] * (x // 10 % 10 + 48).astype(np.uint8)
    out[:, 43] = sci[:, 0] * (x % 10 + 48).astype(np.uint8)
    return out


def format_ints(values) -> np.ndarray:
    """Decimal text of int64 values as an (n, 20) uint8 array (zero bytes = nothing)."""
    v = np.asarray(values, np.int64).ravel()
    neg = v < 0
    u = np.abs(v).astype(np.uint64)
    groups = []
    for _ in range(5):
        u, g = np.divmod(u, _U4)
        groups.append(g)
    dig = np.concatenate([_LUT4[g] for g in groups[::-1]], axis=1)  # 20 digits
    nz = dig != 48
    first = np.where(nz.any(axis=1), np.argmax(nz, axis=1), 19)  # keep one '0'
    dig[np.arange(20)[None, :] < first[:, None]] = 0
    return np.concatenate([(neg * np.uint8(45))[:, None], dig], axis=1)


def stamp_text(sec, nsec) -> np.ndarray:
    """'sec.nnnnnnnnn' (exact decimal seconds of sec + nsec * 1e-9) as a byte array; a negative
    time is '-' and its magnitude ('-4.999999999' for sec -5, nsec 1), and a nanosec field of a
    second or more (not normalised) carries into the seconds, as rclpy's Time reads a stamp."""
    total = np.asarray(sec, np.int64) * np.int64(10**9) + np.asarray(nsec, np.int64)
    mag = np.abs(total).astype(np.uint64)
    s, ns = np.divmod(mag, np.uint64(10**9))
    hi, lo = np.divmod(ns, _U4)
    a, b = np.divmod(hi, _U4)
    frac = np.concatenate(
        [(a.astype(np.uint8) + np.uint8(48))[:, None], _LUT4[b], _LUT4[lo]], axis=1
    )
    whole = format_ints(s.astype(np.int64))
    whole[:, 0] = (total < 0) * np.uint8(45)  # '-'
    return np.concatenate([whole, np.full((len(ns), 1), 46, np.uint8), frac], axis=1)


def _table(strings: list[str], codes: np.ndarray) -> np.ndarray:
    """Byte array of strings[codes]."""
    enc = [s.encode('utf-8') for s in strings]
    w = max([len(b) for b in enc] + [1])
    lut = np.zeros((len(enc), w), np.uint8)
    for i, b in enumerate(enc):
        lut[i, : len(b)] = np.frombuffer(b, np.uint8)
    return lut[np.asarray(codes)]


def csv_header(mech, rates: bool = False) -> list[str]:
    """The columns; with ``rates`` (some command gave velocities) ``velocity.<joint>`` too."""
    return (
        ['time', 'receive_time', 'topic']
        + [f'input.{a}' for a in mech.output_input_names]
        + [f'joint.{j}' for j in mech.output_joint_names]
        + ([f'velocity.{j}' for j in mech.output_joint_names] if rates else [])
        + [f'{p}.{c}' for p in mech.points for c in ('x', 'y')]
        + ['residual', 'margin', 'branch', 'status', 'reason']
    )


def _csv_field(s: str) -> str:
    if any(c in s for c in ',"\n\r'):
        return '"' + s.replace('"', '""') + '"'
    return s


def write_csv(
    path: Path,
    data: Commands,
    res: Results,
    mech,
    progress: Progress | None = None,
    block: int = 50_000,
):
    """One row per command, in bag order (see the module docstring for the columns)."""
    progress = progress or Progress(False)
    n = data.n
    progress.start('csv', n)
    comma = None
    topics = [_csv_field(text_cell(t)) for t in data.topics]
    status_names = ['error', 'ok']
    with written_whole(path) as tmp, open(tmp, 'wb') as fh:
        rates = res.has_rates
        fh.write((','.join(csv_header(mech, rates)) + '\n').encode())
        for a in range(0, n, block):
            b = min(n, a + block)
            m = b - a
            sl = slice(a, b)
            if comma is None or comma.shape[0] != m:
                comma = np.full((m, 1), 44, np.uint8)
                newline = np.full((m, 1), 10, np.uint8)
            ns = data.log_ns[sl]
            cols = [
                stamp_text(data.sec[sl], data.nanosec[sl]),
                comma,
                stamp_text(0, ns),
                comma,
                _table(topics, data.topic[sl]),
                comma,
            ]
            inputs = mech.output_inputs({a: res.inputs[a][sl] for a in mech.actuators})
            for nm, values in zip(mech.actuators, inputs):
                text = format_floats(np.asarray(values, np.float64), b'nan')
                absent = ~(res.ok[sl] | res.input_given[nm][sl])
                if absent.any():  # a refused request that did not name it
                    text = text.copy()
                    text[absent] = 0
                cols += [text, comma]
            scene = {j: res.joints[j][sl] for j in mech.joint_names}
            for values in mech.output_joints(scene, {x: res.inputs[x][sl] for x in mech.actuators}):
                cols += [
                    format_floats(np.broadcast_to(np.asarray(values, np.float64), (m,))),
                    comma,
                ]
            if rates:
                for values in mech.output_joint_rates({j: res.joint_rates[j][sl] for j in scene}):
                    cols += [
                        format_floats(np.broadcast_to(np.asarray(values, np.float64), (m,))),
                        comma,
                    ]
            for p in mech.points:
                cols += [
                    format_floats(res.points[p][sl, 0]),
                    comma,
                    format_floats(res.points[p][sl, 1]),
                    comma,
                ]
            cols += [
                format_floats(res.residual[sl]),
                comma,
                format_floats(res.margin[sl]),
                comma,
                _table(res.branch_names, res.branch_code[sl]),
                comma,
                _table(status_names, res.ok[sl].astype(np.int64)),
                comma,
            ]
            bad = [
                (i, _csv_field(text_cell(res.reason[a + i] or '')).encode('utf-8'))
                for i in np.flatnonzero(~res.ok[sl]).tolist()
            ]
            width = max([len(r) for _, r in bad] + [1])
            reason = np.zeros((m, width), np.uint8)
            for i, r in bad:
                reason[i, : len(r)] = np.frombuffer(r, np.uint8)
            cols += [reason, newline]
            flat = np.concatenate(cols, axis=1).ravel()
            fh.write(flat[flat != 0].tobytes())
            progress.update(b)
    progress.finish()
