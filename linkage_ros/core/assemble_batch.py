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
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .assemble import Assembly, ResultAssembler
from .ops import BATCH, CArray
from .plan import ReadKind, SpecReader


def assemble_batch(asm: ResultAssembler, poses: Any, values: Sequence[Any]) -> Assembly:
    """``asm(BATCH, poses, values)``, bit for bit (module docstring): ``poses`` complex batch
    link poses (CArray), ``values`` the (n,) / (n, 2) command arrays."""
    L, phi, rot, T = asm.L, poses.phi, poses.rot, poses.T
    mx, wrap = np.maximum, BATCH.wrap
    read_once: dict[SpecReader, Any] = {}

    def reading(read: SpecReader) -> Any:
        got = read_once.get(read)
        if got is None:
            got = read_once[read] = read(BATCH, poses)
        return got

    inputs = {}
    for a, i, read in asm.inputs:
        inputs[a] = values[i] if i is not None else reading(read)
    joints: dict[str, Any] = {}
    worst: Any = 0.0
    work: _Buffers | None = None
    for name, child, parent, offset, p in asm.revolutes:
        j = phi[child] + offset  # offset + phi[child] - phi[parent]
        j -= phi[parent]
        joints[name] = _wrapped(j)
        if work is None:
            work = _Buffers(j.shape[0])
        # max(|d.real|, |d.imag|) of d = (rot[parent] p + T[parent]) - (rot[child] p + T[child])
        m = work.miss(rot[parent], T[parent], rot[child], T[child], p)
        worst = mx(worst, m) if isinstance(worst, float) else mx(worst, m, out=worst)
    for name, slider, guide, read, p, normal, face in asm.slides:
        joints[name] = reading(read)
        if work is None:
            work = _Buffers(np.shape(joints[name])[0])
        # abs(abs(across + face) - abs(face)), across = off . nrm, off = (rot[slider] p +
        # T[slider]) - (rot[guide] p + T[guide]), nrm = rot[guide] normal
        m = work.face_miss(rot[slider], T[slider], rot[guide], T[guide], p, normal, face)
        worst = mx(worst, m) if isinstance(worst, float) else mx(worst, m, out=worst)
        turn = phi[slider] - phi[guide]  # L * abs(wrap(phi[slider] - phi[guide]))
        turn = _wrapped(turn)
        np.abs(turn, out=turn)
        turn *= L
        worst = mx(worst, turn) if isinstance(worst, float) else mx(worst, turn, out=worst)
    links = {}
    for l, ref in asm.links:
        v = phi[l] + ref  # ref + phi[l]
        links[l] = _wrapped(v)
    for i, read in asm.knowns:
        got, v = reading(read), values[i]
        if read.kind is ReadKind.POINT:
            worst = mx(worst, mx(abs(got.real - v[:, 0]), abs(got.imag - v[:, 1])))
        elif read.kind is ReadKind.ANGLE:
            worst = mx(worst, L * abs(wrap(got - wrap(v))))
        else:
            worst = mx(worst, abs(got - v))
    return Assembly(inputs, joints, links, worst / L)


def _wrapped(v: np.ndarray) -> np.ndarray:
    """ops.wrap of an array the caller owns: that array itself where every angle is in
    (-pi, pi] already (wrap's common case, which returns a copy of it)."""
    if v.size and v.min() > -math.pi and v.max() <= math.pi:  # (NaN: min is NaN)
        return v
    out: np.ndarray = BATCH.wrap(v)
    return out


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
        if all(_uniform(x) for x in (rot.re, rot.im, T.re, T.im)):
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
