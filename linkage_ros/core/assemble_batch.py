"""Reading a batch's solution off its link poses in fewer passes: a twin kept on purpose.

:class:`~linkage_ros.core.assemble.ResultAssembler` is written once for one command and for a
batch; on a batch each revolute joint's closure miss ``(rot_p p + T_p) - (rot_c p + T_c)`` is
about twenty whole-batch passes, each into a fresh array (a 20,000-row float array is 160 kB:
page faults as well as its pass), and the joints, links and residual of a closed-form four-bar
batch cost about as much as its three dyad steps. :func:`assemble_batch` computes exactly the
same float operations in the same order (each comment names the expression), but into a few
buffers it owns and reuses (they stay in cache), takes a pose that is the same in every row (the
ground's: a read-only view of one value, see core.execute) once, and keeps a wrapped angle's
array where every angle is in (-pi, pi] already (what ``ops.wrap`` returns then, copied). Every
value is the generic reading's bit for bit (test/core/test_assemble_batch.py, every packaged
scene, hostile rows included).

The batch solve's peak of fresh memory was here (its poses, the answers and these buffers at
once): with ``release`` the misses come first and each link's rot and T are let go after the
last one that reads them, and the joint and link angles (phi only) are written after.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .assemble import Assembly, ResultAssembler
from .ops import BATCH, CArray
from .plan import ReadKind, SpecReader


def assemble_batch(
    asm: ResultAssembler, poses: Any, values: Sequence[Any], release: bool = False
) -> Assembly:
    """``asm(BATCH, poses, values)``, bit for bit (module docstring): ``poses`` complex batch
    link poses (CArray), ``values`` the (n,) / (n, 2) command arrays. ``release``: the caller
    is done with ``poses``' rotations and offsets: each link's ``rot`` and ``T`` are taken out
    of them as soon as the last miss or reading that needs them is written (the batch's peak
    of memory, and so its page faults, is here: the poses, the answers and the buffers)."""
    L, phi, rot, T = asm.L, poses.phi, poses.rot, poses.T
    mx, wrap = np.maximum, BATCH.wrap
    read_once: dict[SpecReader, Any] = {}
    done_after = _pose_last_reads(asm) if release else {}

    def done(stage: int) -> None:
        for link in done_after.get(stage, ()):
            rot.pop(link, None)
            T.pop(link, None)

    def reading(read: SpecReader) -> Any:
        got = read_once.get(read)
        if got is None:
            got = read_once[read] = read(BATCH, poses)
        return got

    inputs = {}
    for a, i, read in asm.inputs:
        inputs[a] = values[i] if i is not None else reading(read)
    worst: Any = 0.0
    work: _Buffers | None = None
    done(_INPUTS)
    # the misses first, each link's rot and T let go after its last (release); the joint
    # angles, which need phi only, after them: fewer arrays held at once
    for k, (_, child, parent, _, p) in enumerate(asm.revolutes):
        if work is None:
            work = _Buffers(np.shape(phi[child])[0])
        # max(|d.real|, |d.imag|) of d = (rot[parent] p + T[parent]) - (rot[child] p + T[child])
        m = work.miss(rot[parent], T[parent], rot[child], T[child], p)
        worst = mx(worst, m) if isinstance(worst, float) else mx(worst, m, out=worst)
        done(k)
    slid: dict[str, Any] = {}
    for k, (name, slider, guide, read, p, normal, face) in enumerate(
        asm.slides, len(asm.revolutes)
    ):
        slid[name] = reading(read)
        if work is None:
            work = _Buffers(np.shape(slid[name])[0])
        # abs(abs(across + face) - abs(face)), across = off . nrm, off = (rot[slider] p +
        # T[slider]) - (rot[guide] p + T[guide]), nrm = rot[guide] normal
        m = work.face_miss(rot[slider], T[slider], rot[guide], T[guide], p, normal, face)
        worst = mx(worst, m) if isinstance(worst, float) else mx(worst, m, out=worst)
        turn = phi[slider] - phi[guide]  # L * abs(wrap(phi[slider] - phi[guide]))
        turn = _wrapped(turn)
        np.abs(turn, out=turn)
        turn *= L
        worst = mx(worst, turn) if isinstance(worst, float) else mx(worst, turn, out=worst)
        done(k)
    del work  # (the buffers let go before the angles below are written)
    joints: dict[str, Any] = {}
    for name, child, parent, offset, _ in asm.revolutes:
        j = phi[child] + offset  # offset + phi[child] - phi[parent]
        j -= phi[parent]
        joints[name] = _wrapped(j)
    joints.update(slid)
    links = {}
    for l, ref in asm.links:
        v = phi[l] + ref  # ref + phi[l]
        links[l] = _wrapped(v)
    for i, read in asm.knowns:
        got, v = reading(read), values[i]
        if read.kind is ReadKind.POINT:
            worst = mx(worst, mx(abs(got.real - v[:, 0]), abs(got.imag - v[:, 1])))
        elif read.kind is ReadKind.ANGLE:  # L * abs(wrap(got - wrap(v))), in one array
            want = wrap(v)  # (a new array: wrap's copy)
            miss = _wrapped(np.subtract(got, want, out=want) if _rows_of(want, got) else got - want)
            np.abs(miss, out=miss)
            np.multiply(miss, L, out=miss)
            worst = mx(worst, miss) if isinstance(worst, float) else mx(worst, miss, out=worst)
        else:
            worst = mx(worst, abs(got - v))
    return Assembly(inputs, joints, links, worst / L)


#: the stage of the input readings (before the first miss; see _pose_last_reads)
_INPUTS = -1


def _pose_last_reads(asm: ResultAssembler) -> dict[int, list[str]]:
    """The links whose rot and T no stage of assemble_batch reads after stage k, by k: the
    input readings (_INPUTS), each revolute miss (its index), each slide (len(revolutes) +
    its index); a link a known's point or slide reading needs (read last, unless read
    before) never."""
    last: dict[str, int] = {}

    def reads(r: SpecReader) -> tuple[str, ...]:
        if r.kind is ReadKind.ANGLE:
            return ()
        return (r.link,) if r.kind is ReadKind.POINT else (r.link, r.reference)

    for _, i, r in asm.inputs:
        if i is None:
            last.update(dict.fromkeys(reads(r), _INPUTS))
    for k, (_, child, parent, _, _) in enumerate(asm.revolutes):
        last[child] = last[parent] = k
    for k, (_, slider, guide, r, *_) in enumerate(asm.slides, len(asm.revolutes)):
        last[slider] = last[guide] = k
        last.update(dict.fromkeys(reads(r), k))
    # a known's reading made before (the same reader: read once) needs no pose at the end
    earlier = {r for _, i, r in asm.inputs if i is None} | {s[3] for s in asm.slides}
    keep = {l for _, r in asm.knowns if r not in earlier for l in reads(r)}
    by_stage: dict[int, list[str]] = {}
    for link, k in last.items():
        if link not in keep:
            by_stage.setdefault(k, []).append(link)
    return by_stage


def _wrapped(v: np.ndarray) -> np.ndarray:
    """ops.wrap of an array the caller owns: that array itself where every angle is in
    (-pi, pi] already (wrap's common case, which returns a copy of it)."""
    if v.size and v.min() > -math.pi and v.max() <= math.pi:  # (NaN: min is NaN)
        return v
    out: np.ndarray = BATCH.wrap(v)
    return out


def _rows_of(a: Any, b: Any) -> bool:
    """a is an (n,) float array b's shape: what b - a can be written into."""
    return isinstance(a, np.ndarray) and a.ndim == 1 and np.shape(b) == a.shape and a.dtype == float


def _uniform(x: Any) -> bool:
    """An (n,) array that is one value in every row (a read-only view of it: stride 0)."""
    return isinstance(x, np.ndarray) and x.ndim == 1 and x.size > 0 and x.strides == (0,)


class _Buffers:
    """Five (n,) arrays the closure misses of one batch are written into."""

    def __init__(self, n: int):
        self.a_re, self.a_im, self.b_re, self.b_im, self.t = (np.empty(n) for _ in range(5))

    def placed(self, rot: Any, T: Any, p: complex, re: np.ndarray, im: np.ndarray) -> Any:
        """rot * p + T (CArray's operators), into re, im; one value (0-d) where rot and T are
        the same in every row."""
        if not (isinstance(rot, CArray) and isinstance(T, CArray)):
            return rot * p + T
        if _uniform(rot.re) and _uniform(rot.im) and _uniform(T.re) and _uniform(T.im):
            one = CArray(rot.re[0], rot.im[0]) * p + CArray(T.re[0], T.im[0])
            return CArray(np.float64(one.re), np.float64(one.im))
        t = self.t
        np.multiply(rot.re, p.real, out=re)
        re -= np.multiply(rot.im, p.imag, out=t)
        re += T.re
        np.multiply(rot.re, p.imag, out=im)
        im += np.multiply(rot.im, p.real, out=t)
        im += T.im
        return CArray(re, im)

    def difference(self, rot_p: Any, T_p: Any, rot_c: Any, T_c: Any, p: complex) -> Any:
        """d = (rot_p p + T_p) - (rot_c p + T_c) as two (n,) buffers (re, im)."""
        a = self.placed(rot_p, T_p, p, self.a_re, self.a_im)
        b = self.placed(rot_c, T_c, p, self.b_re, self.b_im)
        if not (b.re is self.b_re or a.re is self.a_re):  # neither in a buffer: rows of d
            d = a - b
            np.copyto(self.a_re, d.real)
            np.copyto(self.a_im, d.imag)
            return self.a_re, self.a_im
        out_re = self.b_re if b.re is self.b_re else self.a_re
        out_im = self.b_im if b.re is self.b_re else self.a_im
        return np.subtract(a.re, b.re, out=out_re), np.subtract(a.im, b.im, out=out_im)

    def miss(self, rot_p: Any, T_p: Any, rot_c: Any, T_c: Any, p: complex) -> np.ndarray:
        """max(|d.real|, |d.imag|) of d = (rot_p p + T_p) - (rot_c p + T_c), into a buffer."""
        d_re, d_im = self.difference(rot_p, T_p, rot_c, T_c, p)
        m: np.ndarray = np.maximum(np.abs(d_re, out=d_re), np.abs(d_im, out=d_im), out=d_re)
        return m

    def face_miss(
        self, rot_s: Any, T_s: Any, rot_g: Any, T_g: Any, p: complex, normal: complex, face: float
    ) -> np.ndarray:
        """abs(abs(across + face) - abs(face)), across = off.real nrm.real + off.imag nrm.imag,
        off = (rot_s p + T_s) - (rot_g p + T_g), nrm = rot_g * normal; into a buffer."""
        off_re, off_im = self.difference(rot_s, T_s, rot_g, T_g, p)
        nrm = rot_g * normal
        np.multiply(off_re, nrm.real, out=off_re)
        off_re += np.multiply(off_im, nrm.imag, out=off_im)
        off_re += face
        np.abs(off_re, out=off_re)
        off_re -= abs(face)
        m: np.ndarray = np.abs(off_re, out=off_re)
        return m
