"""Quaternions, rotations and the integration of angular-rate sequences.

Conventions
-----------
Quaternions are Hamilton quaternions stored **scalar first**, ``q = [w, x, y, z]``,
as float64 arrays of shape (..., 4). A unit quaternion ``q`` rotates a vector
from the body frame to the reference frame, ``v_ref = R(q) · v_body``; the
attitude of a body turning with body-frame rate ``ω`` obeys

    q̇ = ½ · q ⊗ [0, ω]                                            (Zhang 2021, eq. 12)

with ``R(q)`` the matrix of Zhang 2021, eq. (13). :func:`to_scipy` and
:func:`from_scipy` convert to and from :class:`scipy.spatial.transform.Rotation`
(which stores scalar last).

Integration
-----------
Between samples ``k`` and ``k+1`` the rate is taken as linear in time, so the
classic fourth-order Runge–Kutta step uses ``ω_k`` at the start, the mid-step
rate ``(ω_k + ω_{k+1}) / 2`` and ``ω_{k+1}`` at the end (Zhang 2021, eq. 23 is
the first-order special case). Because the equation is linear in ``q`` and every
stage multiplies ``q`` on the right, one RK4 step is ``q_{k+1} = q_k ⊗ S_k`` with

    K1 = ½ω_k,  K2 = (1 + h/2·K1) ⊗ ½ω_m,  K3 = (1 + h/2·K2) ⊗ ½ω_m,
    K4 = (1 + h·K3) ⊗ ½ω_{k+1},  S_k = 1 + h/6·(K1 + 2K2 + 2K3 + K4).

So the attitude change over an interval is the ordered product ``S_0 ⊗ … ⊗ S_{n-1}``
(normalised once: scaling commutes with the product, so this equals normalising
after every step). The step factors are computed for all samples at once and the
products are formed by pairwise (tree) reduction, which vectorises the
integration over time steps and over many intervals together.
"""

from __future__ import annotations

import functools
import sys
import weakref
from collections.abc import Callable, Iterator
from typing import NamedTuple

import numpy as np

__all__ = [
    "quat_multiply",
    "quat_conjugate",
    "quat_normalize",
    "quat_to_matrix",
    "matrix_to_quat",
    "quat_from_rotvec",
    "quat_to_rotvec",
    "rk4_step_factors",
    "integrate",
    "integrate_intervals",
    "IntervalIntegrator",
    "to_scipy",
    "from_scipy",
    "skew",
    "angle_between",
    "five_point_derivative",
    "segmented_five_point",
]

_IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of scalar-first quaternions, broadcast over leading axes."""
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            pw * qw - px * qx - py * qy - pz * qz,
            pw * qx + px * qw + py * qz - pz * qy,
            pw * qy - px * qz + py * qw + pz * qx,
            pw * qz + px * qy - py * qx + pz * qw,
        ],
        axis=-1,
    )


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    """Conjugate ``[w, -x, -y, -z]`` (the inverse of a unit quaternion)."""
    q = np.asarray(q, dtype=np.float64)
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_normalize(q: np.ndarray) -> np.ndarray:
    """Scale quaternions to unit norm."""
    q = np.asarray(q, dtype=np.float64)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (Zhang 2021, eq. 13)."""
    q = quat_normalize(q)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    r = np.empty(q.shape[:-1] + (3, 3))
    r[..., 0, 0] = 1 - 2 * (y * y + z * z)
    r[..., 0, 1] = 2 * (x * y - w * z)
    r[..., 0, 2] = 2 * (x * z + w * y)
    r[..., 1, 0] = 2 * (x * y + w * z)
    r[..., 1, 1] = 1 - 2 * (x * x + z * z)
    r[..., 1, 2] = 2 * (y * z - w * x)
    r[..., 2, 0] = 2 * (x * z - w * y)
    r[..., 2, 1] = 2 * (y * z + w * x)
    r[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return r


def matrix_to_quat(r: np.ndarray) -> np.ndarray:
    """Unit quaternions (scalar first, ``w >= 0``) of rotation matrices (..., 3, 3)."""
    r = np.asarray(r, dtype=np.float64)
    m = r.reshape(-1, 3, 3)
    tr = np.trace(m, axis1=1, axis2=2)
    # Four candidate solutions; use the one with the largest pivot for accuracy.
    cand = np.stack(
        [
            1 + tr,
            1 + 2 * m[:, 0, 0] - tr,
            1 + 2 * m[:, 1, 1] - tr,
            1 + 2 * m[:, 2, 2] - tr,
        ],
        axis=1,
    )
    k = np.argmax(cand, axis=1)
    q = np.empty((m.shape[0], 4))
    s = np.sqrt(np.maximum(cand[np.arange(len(k)), k], 1e-300))
    for case in range(4):
        sel = k == case
        if not np.any(sel):
            continue
        mm, ss = m[sel], s[sel]
        if case == 0:
            q[sel] = np.stack([ss / 2, (mm[:, 2, 1] - mm[:, 1, 2]) / (2 * ss),
                               (mm[:, 0, 2] - mm[:, 2, 0]) / (2 * ss),
                               (mm[:, 1, 0] - mm[:, 0, 1]) / (2 * ss)], axis=1)
        elif case == 1:
            q[sel] = np.stack([(mm[:, 2, 1] - mm[:, 1, 2]) / (2 * ss), ss / 2,
                               (mm[:, 0, 1] + mm[:, 1, 0]) / (2 * ss),
                               (mm[:, 0, 2] + mm[:, 2, 0]) / (2 * ss)], axis=1)
        elif case == 2:
            q[sel] = np.stack([(mm[:, 0, 2] - mm[:, 2, 0]) / (2 * ss),
                               (mm[:, 0, 1] + mm[:, 1, 0]) / (2 * ss), ss / 2,
                               (mm[:, 1, 2] + mm[:, 2, 1]) / (2 * ss)], axis=1)
        else:
            q[sel] = np.stack([(mm[:, 1, 0] - mm[:, 0, 1]) / (2 * ss),
                               (mm[:, 0, 2] + mm[:, 2, 0]) / (2 * ss),
                               (mm[:, 1, 2] + mm[:, 2, 1]) / (2 * ss), ss / 2], axis=1)
    q = quat_normalize(q)
    q[q[:, 0] < 0] *= -1
    return q.reshape(r.shape[:-2] + (4,))


def quat_from_rotvec(v: np.ndarray) -> np.ndarray:
    """Quaternions of rotation vectors (axis · angle [rad]), shape (..., 3) → (..., 4)."""
    v = np.asarray(v, dtype=np.float64)
    angle = np.linalg.norm(v, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(x/2)/x, with its series near zero
    small = angle < 1e-8
    safe = np.where(small, 1.0, angle)
    k = np.where(small, 0.5 - angle**2 / 48.0, np.sin(half) / safe)
    return np.concatenate([np.cos(half), v * k], axis=-1)


def quat_to_rotvec(q: np.ndarray) -> np.ndarray:
    """Rotation vectors (..., 3) of quaternions, angle in [0, π]."""
    q = quat_normalize(q)
    q = np.where(q[..., :1] < 0, -q, q)
    vn = np.linalg.norm(q[..., 1:], axis=-1, keepdims=True)
    angle = 2 * np.arctan2(vn, q[..., :1])
    small = vn < 1e-12
    k = np.where(small, 2.0, angle / np.where(small, 1.0, vn))
    return q[..., 1:] * k


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[v]×`` (..., 3, 3) with ``[v]× u = v × u``."""
    v = np.asarray(v, dtype=np.float64)
    z = np.zeros(v.shape[:-1])
    return np.stack(
        [
            np.stack([z, -v[..., 2], v[..., 1]], axis=-1),
            np.stack([v[..., 2], z, -v[..., 0]], axis=-1),
            np.stack([-v[..., 1], v[..., 0], z], axis=-1),
        ],
        axis=-2,
    )


def angle_between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle [rad] between vectors (..., 3), robust for small and large angles."""
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    return np.arctan2(np.linalg.norm(np.cross(u, v), axis=-1), np.sum(u * v, axis=-1))


def to_scipy(q: np.ndarray):
    """A :class:`scipy.spatial.transform.Rotation` from scalar-first quaternions."""
    from scipy.spatial.transform import Rotation  # scipy.spatial.transform costs 327 ms at start-up

    q = np.asarray(q, dtype=np.float64)
    return Rotation.from_quat(q[..., [1, 2, 3, 0]])


def from_scipy(rotation) -> np.ndarray:
    """Scalar-first quaternions from a :class:`scipy.spatial.transform.Rotation`."""
    q = rotation.as_quat()
    return q[..., [3, 0, 1, 2]]


# --------------------------------------------------------------------------- RK4
def _qmul_soa(p: np.ndarray, q: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Hamilton product of quaternions stored component-first, shape (4, ...).

    Written into one output (``out`` when given: not ``p`` or ``q``) with one
    reused temporary (the terms in the order of :func:`quat_multiply`, so the
    same numbers): the integrators call it on many small arrays, where
    allocations cost as much as the arithmetic.
    """
    pw, px, py, pz = p
    qw, qx, qy, qz = q
    shape = pw.shape if pw.shape == qw.shape else np.broadcast_shapes(pw.shape, qw.shape)
    if out is None:
        out = np.empty((4, *shape))
    t = np.empty(out.shape[1:])
    w, x, y, z = out
    mul = np.multiply
    mul(pw, qw, out=w)
    w -= mul(px, qx, out=t)
    w -= mul(py, qy, out=t)
    w -= mul(pz, qz, out=t)
    mul(pw, qx, out=x)
    x += mul(px, qw, out=t)
    x += mul(py, qz, out=t)
    x -= mul(pz, qy, out=t)
    mul(pw, qy, out=y)
    y -= mul(px, qz, out=t)
    y += mul(py, qw, out=t)
    y += mul(pz, qx, out=t)
    mul(pw, qz, out=z)
    z += mul(px, qy, out=t)
    z -= mul(py, qx, out=t)
    z += mul(pz, qw, out=t)
    return out


def _weighted_rotations_soa(q: np.ndarray, weight: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``weight · R(q)`` for quaternions stored component-first (4, ..., L) and weights (..., L).

    Returns an (..., L, 3, 3) view of an array laid out (..., 3, L, 3), so that
    one quaternion sequence's matrices side by side, ``[A_0 A_1 …]`` (3, 3L),
    are contiguous rows (:meth:`IntervalIntegrator.weighted_sum`). The numbers
    are those of ``quat_to_matrix(np.moveaxis(q, 0, -1)) * weight[..., None, None]``
    (the same normalisation and terms, Zhang 2021, eq. 13), formed from
    contiguous components instead of strided ones, :data:`ROTATION_CHUNK`
    quaternions at a time (the temporaries stay small whatever L); ``out``: the
    (..., 3, L, 3) array to write them into.
    """
    r = np.empty(q.shape[1:-1] + (3, q.shape[-1], 3)) if out is None else out
    add, sub, mul = np.add, np.subtract, np.multiply
    # the entries (i, j) of R: 1 − 2(u + v) on the diagonal, 2(u ∓ v) off it, from the products u, v named
    entries = [(0, 0, "yy", add, "zz"), (0, 1, "xy", sub, "wz"), (0, 2, "xz", add, "wy"),
               (1, 0, "xy", add, "wz"), (1, 1, "xx", add, "zz"), (1, 2, "yz", sub, "wx"),
               (2, 0, "xz", sub, "wy"), (2, 1, "yz", add, "wx"), (2, 2, "xx", add, "yy")]
    for a in range(0, q.shape[-1], ROTATION_CHUNK):
        b = min(q.shape[-1], a + ROTATION_CHUNK)
        w, x, y, z = q[..., a:b]
        t = w * w
        t += x * x
        t += y * y
        t += z * z
        norm = np.sqrt(t, out=t)
        w, x, y, z = w / norm, x / norm, y / norm, z / norm
        # each product once (the same numbers as formed in place)
        p = {"xx": x * x, "yy": y * y, "zz": z * z, "xy": x * y, "wz": w * z, "xz": x * z, "wy": w * y,
             "yz": y * z, "wx": w * x}
        weight_ab = weight[..., a:b]
        for i, j, u, op, v in entries:  # each entry times its weight, written once into its place
            op(p[u], p[v], out=t)
            mul(t, 2, out=t)
            if i == j:
                sub(1, t, out=t)
            mul(t, weight_ab, out=r[..., i, a:b, j])
    return np.swapaxes(r, -3, -2)


def _cross_into(u: np.ndarray, v: np.ndarray, out: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``u × v`` of component-first (3, n) vectors into ``out`` (not ``u`` or ``v``), ``t`` a (n,) scratch."""
    mul = np.multiply
    mul(u[1], v[2], out=out[0])
    out[0] -= mul(u[2], v[1], out=t)
    mul(u[2], v[0], out=out[1])
    out[1] -= mul(u[0], v[2], out=t)
    mul(u[0], v[1], out=out[2])
    out[2] -= mul(u[1], v[0], out=t)
    return out


def _rk4_constants(h: np.ndarray | float) -> tuple:
    """The factors of :func:`_rk4_soa` that depend on the step lengths only: ``−h/2``, ``h/2``, ``h²/4``,
    ``h²/2``, ``h/6`` (formed as it forms them; an integrator keeps them for its steps)."""
    hh = np.multiply(h, h)
    return np.multiply(-0.5, h), np.multiply(0.5, h), 0.25 * hh, 0.5 * hh, np.divide(h, 6.0)


def _rk4_soa(w0: np.ndarray, w1: np.ndarray, h: np.ndarray | float, constants: tuple | None = None) -> np.ndarray:
    """RK4 step factors for rates stored component-first (3, n) → (4, n).

    The stages of the module docstring expanded with the pure-quaternion product
    ``(s₁, v₁) ⊗ (s₂, v₂) = (s₁s₂ − v₁·v₂, s₁v₂ + s₂v₁ + v₁ × v₂)`` and
    ``A = ½ω_k``, ``B = ½ω_m``, ``C = ½ω_{k+1}``::

        K1 = (0, A)
        K2 = (−h/2 A·B, B + h/2 A×B)
        K3 = (−h/2 B·B, (1 − h²/4 A·B) B + h²/4 (A×B)×B)
        K4 = (−V·C, s C + V×C),  s = 1 − h²/2 B·B,  V = h · vec(K3)

    Each term is formed as written, left to right (``−h/2 A·B`` is ``(−0.5 h)(A·B)``,
    the sums ``(K1 + 2K2) + 2K3 + K4``), in a few reused buffers: the
    integrators call this on every cost evaluation, where fresh temporaries cost
    as much as the arithmetic. ``constants``: :func:`_rk4_constants` of ``h``
    when formed already.
    """
    if np.ndim(w0) == 1:  # one step: as a sequence of one (the buffers need arrays)
        return _rk4_soa(np.reshape(w0, (3, 1)), np.reshape(w1, (3, 1)), np.reshape(h, (-1,)))[:, 0]
    shape = np.broadcast_shapes(np.shape(w0)[1:], np.shape(w1)[1:])
    mul = np.multiply
    a = 0.5 * w0
    b = np.add(w0, w1)
    b *= 0.25
    c = 0.5 * w1
    ab = np.einsum("i...,i...->...", a, b)
    bb = np.einsum("i...,i...->...", b, b)
    t = np.empty(shape)
    axb = _cross_into(a, b, np.empty((3, *shape)), t)
    minus_half, half, quarter, half_hh, sixth = _rk4_constants(h) if constants is None else constants
    k3s = mul(minus_half, bb)  # −h/2 B·B
    k2s = mul(minus_half, ab)  # −h/2 A·B
    k2v = mul(half, axb)
    k2v += b
    k3v = mul(quarter, ab)
    np.subtract(1.0, k3v, out=k3v)
    k3v = k3v * b
    cross = _cross_into(axb, b, np.empty((3, *shape)), t)
    cross *= quarter
    k3v += cross
    v = mul(h, k3v)
    k4s = np.einsum("i...,i...->...", v, c)
    np.negative(k4s, out=k4s)
    k4v = mul(half_hh, bb)
    np.subtract(1.0, k4v, out=k4v)
    k4v = k4v * c
    k4v += _cross_into(v, c, cross, t)
    out = np.empty((4, *shape))
    k2s *= 2.0
    k2s += mul(2.0, k3s, out=k3s)
    k2s += k4s
    k2s *= sixth
    np.add(1.0, k2s, out=out[0])
    a += mul(2.0, k2v, out=k2v)
    a += mul(2.0, k3v, out=k3v)
    a += k4v
    mul(sixth, a, out=out[1:])
    return out


def rk4_step_factors(w0: np.ndarray, w1: np.ndarray, dt: np.ndarray | float) -> np.ndarray:
    """Right factors ``S`` of RK4 steps, ``q_{k+1} = q_k ⊗ S_k`` (see module docstring).

    Parameters
    ----------
    w0, w1 : (..., 3) array_like
        Body rates [rad/s] at the start and end of each step.
    dt : float or (...,) array_like
        Step lengths [s].

    Returns
    -------
    (..., 4) ndarray
        Step factors (not normalised; their norm is 1 + O(h⁵)).
    """
    w0 = np.asarray(w0, dtype=np.float64)
    w1 = np.asarray(w1, dtype=np.float64)
    h = np.asarray(dt, dtype=np.float64)
    s = _rk4_soa(np.moveaxis(w0, -1, 0), np.moveaxis(w1, -1, 0), h)
    return np.moveaxis(s, 0, -1)


def _tree_product_soa(f: np.ndarray) -> np.ndarray:
    """Ordered product along the last axis of (4, ..., L) component-first quaternions."""
    while f.shape[-1] > 1:
        if f.shape[-1] % 2:
            pad = np.zeros(f.shape[:-1] + (1,))
            pad[0] = 1.0
            f = np.concatenate([f, pad], axis=-1)
        f = _qmul_soa(f[..., 0::2], f[..., 1::2])
    return f[..., 0]


@functools.lru_cache(maxsize=64)
def _bit_reversal(width: int) -> np.ndarray:
    """The order ``p → bitrev(p)`` of ``log2(width)`` bits: storing a sequence so, the pairs ``(2i, 2i + 1)`` of
    every level of its tree product lie in the two halves, ``i`` at the same place in each."""
    bits = width.bit_length() - 1
    if width != 1 << bits:
        raise ValueError("the bit-reversed order needs a power-of-two length")
    order = np.zeros(width, dtype=np.intp)
    for b in range(bits):
        order |= ((np.arange(width) >> b) & 1) << (bits - 1 - b)
    order.flags.writeable = False  # shared by every caller
    return order


def _tree_products_halves(fs: list[np.ndarray], levels: list[np.ndarray] | None = None) -> np.ndarray:
    """:func:`_tree_product_soa` of each (4, W_i, m_i) stored in :func:`_bit_reversal` order along axis 1
    (widths powers of two, widest first), (4, rows of all of them) in that order.

    Each level multiplies the first half by the second, contiguous blocks, the
    same pairs in the same order as the interleaved reduction (the same
    numbers); the widest are reduced alone until they are as narrow as the
    next ones, then both go on together. ``levels``, when given, receives each
    level's products, widest first: the pairs :func:`_prefix_products_halves`
    forms on its way down.
    """
    out = None
    for part in fs:
        if out is not None:
            while out.shape[1] > part.shape[1]:
                out = _halve(out, levels)
            part = np.concatenate([out, part], axis=2)
        out = part
    while out.shape[1] > 1:
        out = _halve(out, levels)
    return out[:, 0]


def _halve(f: np.ndarray, levels: list[np.ndarray] | None) -> np.ndarray:
    """The products of the two halves of ``f`` along axis 1, kept in ``levels`` when given."""
    half = f.shape[1] // 2
    out = _qmul_soa(f[:, :half], f[:, half:])
    if levels is not None:
        levels.append(out)
    return out


def _prefix_product_soa(f: np.ndarray, carry: np.ndarray | None = None) -> np.ndarray:
    """Inclusive ordered prefix products along the last axis of (4, ..., L), L a power of two.

    Work-efficient recursion: the prefix of the pairwise products gives every
    odd position; each even position is the previous odd one times its factor.
    ``carry`` (4, ...) is the product of what came before (a block of a longer
    sequence): it multiplies every prefix from the left, at the recursion's
    coarsest level, so that the block's prefixes are formed in the order the
    whole sequence's would be (:meth:`IntervalIntegrator.sensitivity`).
    """
    n = f.shape[-1]
    if n == 1:
        return f.copy() if carry is None else _qmul_soa(carry[..., None], f)
    if n % 2:
        raise ValueError("the prefix product needs a power-of-two length")
    pairs = _prefix_product_soa(_qmul_soa(f[..., 0::2], f[..., 1::2]), carry)
    out = np.empty_like(f)
    out[..., 1::2] = pairs
    out[..., 0] = f[..., 0] if carry is None else _qmul_soa(carry, f[..., 0])
    out[..., 2::2] = _qmul_soa(pairs[..., :-1], f[..., 2::2])
    return out


def _prefix_products_halves(fs: list[np.ndarray], levels: Iterator[np.ndarray] | None = None) -> list[np.ndarray]:
    """:func:`_prefix_product_soa` of each (4, W_i, m_i) stored in :func:`_bit_reversal` order along axis 1
    (widths powers of two, widest first), returned in the same order.

    The work-efficient recursion on bit-reversed storage: the even positions
    are the first half and the odd ones the second, so the pairwise products
    are one product of contiguous halves (as :func:`_tree_products_halves`);
    the prefix of the pairs gives every odd position as it is, and each even
    position ``i ≥ 2`` is the pair prefix ``i/2 − 1`` times its own factor,
    the pair prefixes moved to those places by one gather. The widest are
    paired alone until they are as narrow as the next ones, then both go on
    together: every product is the one the interleaved recursion forms (the
    same numbers), on contiguous blocks. ``levels``: the pairs of every level,
    widest first, when :func:`_tree_products_halves` has formed them from the
    same factors (they are not formed again).
    """
    width = fs[0].shape[1]
    k = 1
    while k < len(fs) and fs[k].shape[1] == width:
        k += 1
    f = fs[0] if k == 1 else np.concatenate(fs[:k], axis=2)
    rest = fs[k:]
    if width == 1:
        out, inner = f.copy(), []
    else:
        half = width // 2
        even, odd = f[:, :half], f[:, half:]
        pairs, *inner = _prefix_products_halves([_qmul_soa(even, odd) if levels is None else next(levels), *rest],
                                                levels)
        out = np.empty_like(f)
        out[:, half:] = pairs
        _qmul_soa(pairs.take(_previous_pair(half), axis=1), even, out=out[:, :half])
        out[:, 0] = even[:, 0]
    if k == 1:
        return [out, *inner]
    rows = np.cumsum([g.shape[2] for g in fs[:k]])[:-1]
    return [*np.split(out, rows, axis=2), *inner]


@functools.lru_cache(maxsize=64)
def _previous_pair(half: int) -> np.ndarray:
    """For bit-reversed storage of ``half`` pair prefixes: at the place of pair ``j`` that of pair ``j − 1``
    (of pair 0 for ``j = 0``, a place :func:`_prefix_products_halves` overwrites)."""
    order = _bit_reversal(half)
    out = order[np.maximum(order - 1, 0)]
    out.flags.writeable = False  # shared by every caller
    return out


def _tree_product(f: np.ndarray) -> np.ndarray:
    """Ordered product along axis -2 of (..., L, 4)."""
    return np.moveaxis(_tree_product_soa(np.moveaxis(f, -1, 0)), 0, -1)


def _prefix_product(f: np.ndarray) -> np.ndarray:
    """Inclusive ordered prefix products along axis -2 (Hillis–Steele scan)."""
    g = np.ascontiguousarray(np.moveaxis(f, -1, 0))
    n = g.shape[-1]
    shift = 1
    while shift < n:
        g[..., shift:] = _qmul_soa(g[..., :-shift], g[..., shift:])
        shift *= 2
    return np.moveaxis(g, 0, -1)


def integrate(
    t: np.ndarray, rates: np.ndarray, q0: np.ndarray | None = None
) -> np.ndarray:
    """Attitude trajectory from a body-rate sequence by RK4.

    Parameters
    ----------
    t : (N,) array_like
        Sample times [s].
    rates : (N, 3) array_like
        Body angular rates [rad/s].
    q0 : (4,) array_like, optional
        Attitude at ``t[0]`` (identity by default).

    Returns
    -------
    (N, 4) ndarray
        Unit attitude quaternions at every sample.
    """
    t = np.asarray(t, dtype=np.float64)
    rates = np.asarray(rates, dtype=np.float64)
    if rates.ndim != 2 or rates.shape[1] != 3 or rates.shape[0] != t.shape[0]:
        raise ValueError(f"rates must have shape ({t.shape[0]}, 3); got {rates.shape}")
    q0 = _IDENTITY if q0 is None else quat_normalize(q0)
    if t.shape[0] == 1:
        return q0[None, :].copy()
    s = rk4_step_factors(rates[:-1], rates[1:], np.diff(t))
    pre = _prefix_product(s)
    out = np.empty((t.shape[0], 4))
    out[0] = q0
    out[1:] = quat_multiply(q0, pre)
    return quat_normalize(out)


def integrate_intervals(
    rates: np.ndarray, dt: np.ndarray | float, lengths: np.ndarray | None = None
) -> np.ndarray:
    """Attitude change over each of many intervals at once.

    Parameters
    ----------
    rates : (M, L, 3) array_like
        Body rates [rad/s] of M intervals, padded to L samples.
    dt : float or (M, L-1) array_like
        Step lengths [s].
    lengths : (M,) array_like of int, optional
        Number of valid samples in each interval (default L); samples past
        an interval's length are ignored.

    Returns
    -------
    (M, 4) ndarray
        Unit quaternion of each interval's end attitude relative to its start.
    """
    rates = np.asarray(rates, dtype=np.float64)
    m, ell, _ = rates.shape
    s = rk4_step_factors(rates[:, :-1], rates[:, 1:], dt)
    if lengths is not None:
        lengths = np.asarray(lengths)
        invalid = np.arange(ell - 1)[None, :] >= (lengths[:, None] - 1)
        s[invalid] = _IDENTITY
    return quat_normalize(_tree_product(s))


#: steps of one block of a long interval: an interval of more steps is integrated block by block
BLOCK = 1 << 12
#: steps whose integration temporaries exist at once (gathered blocks of long intervals)
CHUNK = 1 << 18
#: steps whose RK4 stages are formed at once: their temporaries stay in the processor's cache (2.4 times as fast
#: as 2^18 at a time)
RK4_CHUNK = 1 << 13

#: the most bytes of gathered RK4 factors whose tree levels :meth:`IntervalIntegrator.from_samples` keeps for
#: :meth:`IntervalIntegrator.sensitivity` (twice this held between them)
LEVEL_BYTES = 1 << 22

#: padded steps of short intervals (up to BLOCK steps) integrated together: a recording of more is integrated a
#: part of consecutive intervals at a time, so that memory does not follow how many short rotations it holds
PART_STEPS = CHUNK

#: samples whose per-sample Jacobians :meth:`IntervalIntegrator.weighted_sum` asks for at once (several short
#: intervals' together)
SPAN = 1 << 12

#: the most steps whose RK4 step-length factors an integrator keeps (five numbers a step: memory that would
#: otherwise follow the length of the recording)
RK4_CONSTANT_STEPS = 1 << 16

#: quaternions turned into weighted rotation matrices at a time (:func:`_weighted_rotations_soa`)
ROTATION_CHUNK = 1 << 12
#: samples of an interval whose weighted sum (:meth:`IntervalIntegrator.weighted_sum`) is one product; a longer
#: interval's is summed block by block
SUM_BLOCK = 1 << 17


class IntervalIntegrator:
    """Repeated integration of many intervals of one recording (for solvers).

    The sample layout is fixed once; :meth:`__call__` then takes rates for
    every sample of the recording (or :meth:`from_samples` only for the
    samples listed in :attr:`samples`) and returns each interval's attitude
    change. This is the inner loop of the gyroscope cost functions (Zhang
    2021, eq. 14; Tedaldi 2014), so it avoids all per-call bookkeeping.

    The temporaries follow neither the length of one interval nor how many
    there are: intervals of up to :data:`BLOCK` steps are grouped by their
    length rounded up to a power of two, each group padded to its own length,
    in parts of consecutive intervals of up to :data:`PART_STEPS` padded steps
    integrated one part at a time (one part, as a rule: a recording of hours of
    short turns has several); a longer interval is cut into blocks of
    :data:`BLOCK` steps, whose products are then multiplied together, and the
    blocks are processed :data:`CHUNK` steps at a time. The blocks are
    aligned on the pairwise (tree) products of the module docstring, and their
    prefix products continue from the blocks before them in the order the
    whole interval's would be formed, so the results are the same to the last
    bit as integrating each interval at once (and, every product being formed
    per interval, in one part or in many).

    Parameters
    ----------
    t : (N,) array_like
        Sample times [s] of the whole recording.
    starts, stops : (M,) array_like of int
        Each interval integrates from sample ``starts[i]`` to sample
        ``stops[i]`` inclusive.
    """

    def __init__(self, t: np.ndarray, starts: np.ndarray, stops: np.ndarray) -> None:
        t = np.asarray(t, dtype=np.float64)
        starts = np.asarray(starts, dtype=np.intp)
        stops = np.asarray(stops, dtype=np.intp)
        if starts.shape != stops.shape or starts.size == 0 or np.any(stops <= starts):
            raise ValueError("each interval needs stops[i] > starts[i]")
        if np.any(starts < 0) or np.any(stops >= t.shape[0]):
            raise ValueError("interval indices lie outside the recording")
        nsteps = stops - starts
        # the steps (sample k → k+1) of every interval, sorted and without repeats
        step = np.zeros(t.shape[0], np.int32)
        np.add.at(step, starts, 1)
        np.add.at(step, stops, -1)
        steps = np.flatnonzero(np.cumsum(step, dtype=np.int32) > 0)
        del step
        used = np.zeros(t.shape[0], bool)  # the samples the steps read: steps and steps + 1, in one pass
        used[steps] = True
        used[steps + 1] = True
        self.samples = np.flatnonzero(used)
        #: positions in ``samples`` of each step's first sample
        #: (the second sample of a step follows its first there: ``_i0 + 1``)
        self._i0 = np.cumsum(used, dtype=np.int32 if used.size < 2**31 else np.intp)[steps]
        self._i0 -= 1
        del used
        dt = t[steps + 1] - t[steps]  # each step's length
        self.starts, self.stops = starts, stops
        self._nsteps = nsteps
        #: position in ``samples`` of each interval's first sample (its samples follow it there)
        self._first = np.searchsorted(self.samples, starts)
        #: position in ``steps`` of each interval's first step (its steps follow it there)
        self._step0 = np.searchsorted(steps, starts)
        #: the RK4 factors are formed for every pair of consecutive samples of ``samples`` (contiguous rates, no
        #: gather; a pair that is no step, from one interval's end to the next one's start, is never read):
        #: their step lengths (0 for those), and the place of each step among them
        self._npairs = self.samples.size - 1
        self._pair_dt = np.zeros(self._npairs)
        self._pair_dt[self._i0] = dt
        del dt
        #: the RK4 factors of the step lengths (:func:`_rk4_constants`), formed once when they are few
        self._rk4_constants = _rk4_constants(self._pair_dt) if self._npairs <= RK4_CONSTANT_STEPS else None
        # intervals grouped by their length rounded up to a power of two: each group is padded to its own
        # length (with identity steps), not to the longest interval's, so memory follows the samples integrated
        widths = 1 << np.ceil(np.log2(np.maximum(nsteps, 1))).astype(int)
        #: the short intervals in parts of consecutive intervals of up to PART_STEPS padded steps (one part, as
        #: a rule): each part's groups, the layout of its attitudes (_ShortPart)
        self._parts = []
        #: per interval: its part (−1 for a long one), and the position of its first attitude in its part's
        self._part_of = np.full(len(starts), -1)
        self._att_first = np.full(len(starts), -1)
        short = np.nonzero(widths <= BLOCK)[0]
        ends = np.cumsum(widths[short])
        a = 0
        while a < short.size:  # each part as many intervals as fit in PART_STEPS (at least one)
            b = max(a + 1, int(np.searchsorted(ends, (ends[a - 1] if a else 0) + PART_STEPS, side="right")))
            self._part_of[short[a:b]] = len(self._parts)
            self._parts.append(self._short_part(short[a:b], widths, nsteps))
            a = b
        #: bytes of the groups' gathered factors (and again of their tree levels), when they form one part
        self._group_bytes = 32 * self._parts[0].columns if len(self._parts) == 1 else None
        #: (the factors, weakly; their gathered columns; their tree levels) of the last from_samples()
        self._tree_levels: tuple | None = None
        #: the rotations array of the last sensitivity() (reused once nothing else refers to it)
        self._rotations: np.ndarray | None = None
        #: sensitivity()'s attitude temporaries (every group's, then every sample's), kept when small
        self._attitude_buffers = None
        if len(self._parts) == 1:
            part = self._parts[0]
            if 32 * (part.columns + 1 + part.att_index.size) <= LEVEL_BYTES:
                self._attitude_buffers = (np.empty((4, part.columns + 1)), np.empty((4, part.att_index.size)))
        # longer intervals: blocks of BLOCK steps, then per interval the product of its blocks (their number
        # rounded up to a power of two, grouped by it)
        self._long = np.nonzero(widths > BLOCK)[0]
        nblocks = -(-nsteps[self._long] // BLOCK)
        self._block_first = np.concatenate([[0], np.cumsum(nblocks)])  # each long interval's first block
        owner = np.repeat(np.arange(self._long.size), nblocks)
        #: per block: position in ``steps`` of its first step, and how many of its steps are the interval's
        self._block_step0 = (self._step0[self._long][owner]
                             + BLOCK * (np.arange(owner.size) - self._block_first[owner]))
        self._block_len = np.minimum(BLOCK, self._step0[self._long][owner] + nsteps[self._long][owner]
                                     - self._block_step0)
        self._long_groups = []
        for count in np.unique(widths[self._long] // BLOCK):
            which = np.nonzero(widths[self._long] // BLOCK == count)[0]  # positions in _long
            pos = np.arange(count)[None, :]
            valid = pos < nblocks[which, None]
            self._long_groups.append((which, np.where(valid, self._block_first[which, None] + pos, owner.size)))

    def _short_part(self, members: np.ndarray, widths: np.ndarray, nsteps: np.ndarray) -> _ShortPart:
        """The groups of the short intervals ``members`` (by width, widest first) and their attitudes' layout."""
        groups, att_index, att_trapezoid = [], [], []
        column = place = 0
        for width in np.unique(widths[members])[::-1]:  # widest first
            group = members[widths[members] == width]
            gather, trapezoid = self._layout(self._step0[group], nsteps[group], int(width))
            order = _bit_reversal(int(width))
            # each group's steps are gathered step-major (W, members) in bit-reversed order (_tree_products_halves)
            groups.append((group, np.ascontiguousarray(gather[:, order].T)))
            # row j's samples: the start (the identity, marked −1), then the attitude after step i at place
            # order[i] of row j; each row as long as its interval's samples
            m, n = len(group), nsteps[group]
            index = np.empty((m, int(width) + 1), dtype=np.intp)
            index[:, 0] = -1
            index[:, 1:] = column + order[None, :] * m + np.arange(m)[:, None]
            real = np.arange(int(width) + 1)[None, :] <= n[:, None]
            att_index.append(index[real])
            att_trapezoid.append(trapezoid[real])
            self._att_first[group] = place + np.concatenate([[0], np.cumsum(n + 1)[:-1]])
            place += int(np.sum(n + 1))
            column += int(width) * len(group)
        att_index = np.concatenate(att_index)
        att_index[att_index < 0] = column  # the start of each interval: the identity
        return _ShortPart(groups, att_index, np.concatenate(att_trapezoid), column)

    def _part_rotations(self, k: int, s: np.ndarray) -> np.ndarray:
        """The ``A_j`` of every sample of part ``k``'s intervals from the RK4 factors ``s`` (:meth:`step_factors`),
        as :meth:`sensitivity` forms them (the same numbers)."""
        part = self._parts[k]
        return self._rotations_of(part, _prefix_products_halves([s.take(tree, axis=1) for _, tree in part.groups]))

    @staticmethod
    def _rotations_of(part: _ShortPart, prefixes: list[np.ndarray], buffers: tuple | None = None,
                      out: np.ndarray | None = None) -> np.ndarray:
        """The ``A_j`` ((samples, 3, 3) view of a (3, samples, 3) array, :func:`_weighted_rotations_soa`) of the
        samples of ``part`` from its groups' prefix products: every attitude, then each sample's (into
        ``buffers`` and ``out`` when given). Empties ``prefixes`` once they are copied (freed before the
        rotations are formed)."""
        att = np.concatenate([pre.reshape(4, -1) for pre in prefixes] + [_IDENTITY[:, None]], axis=1,
                             out=None if buffers is None else buffers[0])
        prefixes.clear()
        att = att.take(part.att_index, axis=1, out=None if buffers is None else buffers[1])
        return _weighted_rotations_soa(att, part.att_trapezoid, out)

    def _layout(self, step0: np.ndarray, nsteps: np.ndarray, width: int) -> tuple[np.ndarray, np.ndarray]:
        """Columns of each interval's steps among the RK4 factors (the identity column past its end), and the
        trapezoid weights of its samples (positions 0..width), for intervals starting at ``step0`` in ``steps``."""
        pos = np.arange(width)[None, :]
        valid = pos < nsteps[:, None]
        step = np.where(valid, step0[:, None] + pos, 0)
        gather = np.where(valid, self._i0[step], self._npairs)
        dtp = np.zeros((len(step0), width + 2))
        dtp[:, 1:-1] = np.where(valid, self._pair_dt[self._i0[step]], 0.0)
        return gather, 0.5 * (dtp[:, :-1] + dtp[:, 1:])

    def __call__(self, rates: np.ndarray) -> np.ndarray:
        """Attitude change (M, 4) of every interval for rates (N, 3) [rad/s]."""
        return self.from_samples(np.asarray(rates, dtype=np.float64)[self.samples])

    def step_factors(self, rates: np.ndarray) -> np.ndarray:
        """RK4 factors (4, len(samples)) of every pair of consecutive :attr:`samples` (the steps among them), then
        an identity column for the padding.

        For :meth:`from_samples` and :meth:`sensitivity` (``steps``) when both integrate the same rates.
        """
        rates = np.asarray(rates, dtype=np.float64)
        n = self._npairs
        s = np.empty((4, n + 1))
        for a in range(0, n, RK4_CHUNK):  # the stages' temporaries RK4_CHUNK steps at a time
            b = min(n, a + RK4_CHUNK)
            chunk = rates[a : b + 1].T.copy()  # the rates component-first, a chunk at a time
            constants = None if self._rk4_constants is None else [c[a:b] for c in self._rk4_constants]
            s[:, a:b] = _rk4_soa(chunk[:, :-1], chunk[:, 1:], self._pair_dt[a:b], constants)
        s[:, n] = _IDENTITY
        return s

    def _steps_at(self, rates: np.ndarray, gather: np.ndarray) -> np.ndarray:
        """RK4 factors (4, *gather.shape) of the columns ``gather`` of :meth:`step_factors` (identity past the
        last), as it forms them."""
        flat = gather.ravel()
        real = flat < self._npairs
        out = np.empty((4, flat.size))
        out[:, ~real] = _IDENTITY[:, None]
        idx = flat[real]
        rates = np.asarray(rates, dtype=np.float64)
        w0, w1 = rates.take(idx, axis=0).T.copy(), rates.take(idx + 1, axis=0).T.copy()
        out[:, real] = _rk4_soa(w0, w1, self._pair_dt[idx])
        return out.reshape((4, *gather.shape))

    def _block_chunks(self):
        """Ranges of long-interval blocks processed together (:data:`CHUNK` steps) and their factor columns."""
        rows = max(1, CHUNK // BLOCK)
        for a in range(0, self._block_step0.size, rows):
            b = min(self._block_step0.size, a + rows)
            gather, _ = self._layout(self._block_step0[a:b], self._block_len[a:b], BLOCK)
            yield a, b, gather

    def _block_prefix(self, products: np.ndarray) -> list[np.ndarray]:
        """Per long interval, the prefix products (4, blocks) of its blocks' products (4, all blocks)."""
        padded = np.concatenate([products, _IDENTITY[:, None]], axis=1)
        out: list[np.ndarray] = [np.empty(0)] * self._long.size
        for which, gather in self._long_groups:
            pre = _prefix_product_soa(padded.take(gather, axis=1))
            for i, k in enumerate(which):
                out[k] = pre[:, i]
        return out

    def from_samples(self, rates: np.ndarray, steps: np.ndarray | None = None) -> np.ndarray:
        """Attitude change (M, 4) from rates (len(samples), 3) at :attr:`samples` only.

        ``steps``: their RK4 factors when already formed (:meth:`step_factors` of these rates).
        """
        s = self.step_factors(rates) if steps is None else steps
        q = np.empty((len(self.starts), 4))
        self._tree_levels = None
        for part in self._parts:  # one part at a time: its temporaries are all that exist at once
            order = np.concatenate([members for members, _ in part.groups])
            fs = [s.take(tree, axis=1) for _, tree in part.groups]
            # the caller keeps these factors: their gathered columns and tree levels kept for sensitivity()'s
            # prefix products of the same factors, when small (and one part)
            keep = steps is not None and self._group_bytes is not None and self._group_bytes <= LEVEL_BYTES
            levels = [] if keep else None
            q[order] = _tree_products_halves(fs, levels).T
            if levels is not None:
                self._tree_levels = (weakref.ref(steps), fs, levels)
            del fs
        if self._long.size:
            products = np.empty((4, self._block_step0.size))
            for a, b, gather in self._block_chunks():
                products[:, a:b] = _tree_product_soa(s.take(gather, axis=1))
            products = np.concatenate([products, _IDENTITY[:, None]], axis=1)
            for which, gather in self._long_groups:
                q[self._long[which]] = _tree_product_soa(products.take(gather, axis=1)).T
        return quat_normalize(q)

    def sensitivity(self, rates: np.ndarray, steps: np.ndarray | None = None
                    ) -> tuple[np.ndarray, _SensitivityWeights]:
        """End attitudes and the weights of the first-order attitude sensitivity.

        A perturbation ``δω`` of the rates turns the end attitude by
        ``δφ = R_endᵀ · Σ_j A_j δω_j`` (end frame), the trapezoidal rule on
        ``∫ R(t) δω(t) dt`` with ``R(t)`` the attitude relative to the
        interval's start. Used for analytic Jacobians of eq. (14) of Zhang 2021.

        Parameters
        ----------
        rates : (len(samples), 3) ndarray
            Rates [rad/s] at :attr:`samples`.
        steps : ndarray, optional
            Their RK4 factors when already formed (:meth:`step_factors`).

        Returns
        -------
        q_end : (M, 4) ndarray
            Attitude change of each interval (as :meth:`from_samples`).
        weights : sequence of M (n_m + 1, 3, 3) ndarrays
            ``A_j`` for the ``n_m + 1`` samples of interval ``m``, in the
            order they have in :attr:`samples` from :attr:`first_sample`
            (those of a long interval are formed when asked for, from the
            RK4 factors and the products of its blocks: :meth:`weighted_sum`
            takes them block by block, and no attitude of every sample exists).
        """
        s = self.step_factors(rates) if steps is None else steps
        q_end = np.empty((len(self.starts), 4))
        weights = _SensitivityWeights(self)
        for part in self._parts:  # pre: the attitude after each step, bit-reversed (W, members) per group
            kept = self._tree_levels
            if steps is not None and kept is not None and kept[0]() is steps:  # from_samples() of these factors
                prefixes = _prefix_products_halves(kept[1], iter(kept[2]))
            else:
                prefixes = _prefix_products_halves([s.take(tree, axis=1) for _, tree in part.groups])
            for (members, _), pre in zip(part.groups, prefixes, strict=True):
                q_end[members] = pre[:, -1].T  # the last place holds the last step in bit-reversed order too
            del pre
            if len(self._parts) == 1:  # its A_j now (temporaries kept by the integrator when small: reused)
                rot = self._rotations_of(part, prefixes, self._attitude_buffers, self._rotations_buffer())
                for members, _ in part.groups:
                    for k in members:
                        weights.items[k] = rot[self._att_first[k] : self._att_first[k] + self._nsteps[k] + 1]
            del prefixes
        if len(self._parts) > 1:  # many short intervals: each part's A_j formed when weighted_sum() reaches it
            weights.factors = s
        if self._long.size:
            products = np.empty((4, self._block_step0.size))
            for a, b, gather in self._block_chunks():
                products[:, a:b] = _tree_product_soa(s.take(gather, axis=1))
            prefix = self._block_prefix(products)
            # a long interval's attitudes are formed again when asked for: from the factors when the caller keeps
            # them anyway, else from the rates
            weights.rates, weights.steps = rates, steps
            for i, k in enumerate(self._long):
                q_end[k] = prefix[i][:, -1]  # the product of all its blocks, as from_samples forms it
                weights.prefix[k] = (i, prefix[i])
        return quat_normalize(q_end), weights

    def _rotations_buffer(self) -> np.ndarray:
        """The (3, samples, 3) array the short intervals' ``A_j`` are written into: the one of the last
        :meth:`sensitivity` again once nothing refers to it any more (its weights and every view of them gone:
        a fit's Jacobians are formed one after the other), else a new one."""
        buf = self._rotations
        self._rotations = None
        if buf is None or sys.getrefcount(buf) > 2:  # 2: the name here and getrefcount's argument
            buf = np.empty((3, self._parts[0].att_index.size, 3))
        self._rotations = buf
        return buf

    def _trapezoid(self, k: int) -> np.ndarray:
        """Trapezoid weights (n + 1,) of the samples of interval ``k``."""
        dt = self._pair_dt[self._first[k] : self._first[k] + self._nsteps[k]]  # its steps: consecutive pairs
        return 0.5 * (np.concatenate([[0.0], dt]) + np.concatenate([dt, [0.0]]))

    @property
    def first_sample(self) -> np.ndarray:
        """(M,) position in :attr:`samples` of each interval's first sample; its others follow it there."""
        return self._first

    def _span_end(self, m: int) -> int:
        """The end of the samples of interval ``m`` and the short intervals after it, up to :data:`SPAN` samples
        from its first (one call of :meth:`weighted_sum`'s ``values``)."""
        p0 = int(self._first[m])
        end = p0 + int(self._nsteps[m]) + 1
        k = m + 1
        while k < len(self._first) and self._first[k] >= p0:
            stop = int(self._first[k] + self._nsteps[k]) + 1
            if self._nsteps[k] + 1 > SUM_BLOCK or stop - p0 > SPAN:
                break
            end = max(end, stop)
            k += 1
        return end

    def weighted_sum(self, weights: _SensitivityWeights,
                     values: np.ndarray | Callable[[int, int], np.ndarray]) -> np.ndarray:
        """``Σ_j A_j v_j`` over each interval's samples: (M, 3, P) from the weights of :meth:`sensitivity`.

        ``values`` (len(samples), 3, P) are per-sample Jacobians (e.g. ``∂ω/∂θ``),
        or a function giving those of the samples at positions ``a … b − 1`` of
        :attr:`samples` (``values(a, b)``, (b − a, 3, P); the array it returns is
        read before the next call, so it may reuse one buffer): then only one
        interval's (or block's) Jacobian exists at a time, whatever the length
        of the recording.
        Each interval's samples are consecutive in :attr:`samples`, so this is
        one (3 × 3n)·(3n × P) product per interval over its own samples, with
        no gathered copy and no work on padding; an interval of more than
        :data:`SUM_BLOCK` samples is summed block by block (its ``A_j`` formed a
        block at a time). Both forms of ``values`` give the same products.
        """
        get = values if callable(values) else (lambda a, b: values[a:b])
        out = None
        span = (0, 0, None)  # samples [a, b) of the values last asked for, and those values
        for m, (p0, n) in enumerate(zip(self._first, self._nsteps + 1, strict=True)):
            if n <= SUM_BLOCK:
                a = weights[m][:n].transpose(1, 0, 2).reshape(3, 3 * n)  # [A_0 A_1 …]
                if not (span[0] <= p0 and p0 + n <= span[1]):  # the values of this and the next short intervals
                    span = (p0, self._span_end(m), None)
                    span = (*span[:2], get(*span[:2]))
                v = span[2][p0 - span[0] : p0 - span[0] + n]
                if out is None:
                    out = np.empty((len(self.starts), 3, v.shape[2]))
                out[m] = a @ v.reshape(3 * n, -1)
                continue
            span = (0, 0, None)  # the values are asked for again: the buffer they lie in is reused
            for j in range(0, n, SUM_BLOCK):
                k = min(n, j + SUM_BLOCK)
                a = weights.block(m, j, k).transpose(1, 0, 2).reshape(3, 3 * (k - j))
                v = get(p0 + j, p0 + k)
                if out is None:
                    out = np.empty((len(self.starts), 3, v.shape[2]))
                if j == 0:
                    out[m] = 0.0
                out[m] += a @ v.reshape(3 * (k - j), -1)
        return out


class _ShortPart(NamedTuple):
    """Consecutive short intervals integrated together (:attr:`IntervalIntegrator._parts`)."""

    #: (members, gathered factor columns (W, members) in bit-reversed order) per width, widest first
    groups: list[tuple[np.ndarray, np.ndarray]]
    #: per attitude of the part's samples: its column among the groups' prefix products (the identity last)
    att_index: np.ndarray
    #: and its trapezoid weight
    att_trapezoid: np.ndarray
    #: the groups' padded steps
    columns: int


class _SensitivityWeights:
    """The ``A_j`` of :meth:`IntervalIntegrator.sensitivity`, one (n + 1, 3, 3) array per interval.

    Those of the short intervals are kept as arrays; those of a long interval
    are formed from its attitudes (4, n + 1) when asked for, whole or a block
    of samples at a time (:meth:`block`), so that no (n + 1, 3, 3) array of a
    long interval has to exist.
    """

    def __init__(self, integrator: IntervalIntegrator) -> None:
        self.integrator = integrator
        self.items: list[np.ndarray | None] = [None] * len(integrator.starts)
        #: per long interval: its place in ``integrator._long`` and the prefix products (4, blocks) of its blocks
        self.prefix: dict[int, tuple[int, np.ndarray]] = {}
        self.rates: np.ndarray | None = None  # the rates (len(samples), 3) the attitudes were integrated from
        self.steps: np.ndarray | None = None  # their RK4 factors, when the caller passed them
        #: the RK4 factors of every step, when the short intervals are in several parts (their A_j formed a part
        #: at a time, from these), and the part last formed: (its number, its A_j)
        self.factors: np.ndarray | None = None
        self._part: tuple[int, np.ndarray | None] = (-1, None)

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, m: int) -> np.ndarray:
        item = self.items[m]
        return item if item is not None else self.block(m, 0, self.integrator._nsteps[m] + 1)

    def _short(self, m: int) -> np.ndarray | None:
        """``A_j`` of short interval ``m`` of an integrator whose short intervals are in several parts (its
        part's formed when first asked for, the one before dropped first), else None."""
        integ = self.integrator
        k = int(integ._part_of[m]) if self.factors is not None else -1
        if k < 0:
            return None
        if self._part[0] != k:
            self._part = (-1, None)  # one part's A_j at a time
            self._part = (k, integ._part_rotations(k, self.factors))
        first = integ._att_first[m]
        return self._part[1][first : first + integ._nsteps[m] + 1]

    def attitudes(self, m: int, start: int, stop: int) -> np.ndarray:
        """Attitudes (4, stop − start) of samples ``start … stop − 1`` of long interval ``m`` (relative to its start).

        The RK4 factors of the blocks holding them and their prefix products,
        each continuing from the product of the blocks before it (``carry``),
        formed exactly as :meth:`IntervalIntegrator.sensitivity` formed every
        block's: the same numbers as the attitudes of the whole interval,
        without keeping the factors or attitudes of every step.
        """
        integ = self.integrator
        i, prefix = self.prefix[m]
        first = int(integ._block_first[i])
        c0 = max(start - 1, 0) // BLOCK  # sample p ≥ 1 is the attitude after step p − 1
        c1 = max(stop - 2, 0) // BLOCK + 1
        blocks = np.arange(first + c0, first + c1)
        gather, _ = integ._layout(integ._block_step0[blocks], integ._block_len[blocks], BLOCK)
        carry = np.empty((4, c1 - c0))
        for c in range(c0, c1):
            carry[:, c - c0] = _IDENTITY if c == 0 else prefix[:, c - 1]
        factors = integ._steps_at(self.rates, gather) if self.steps is None else self.steps.take(gather, axis=1)
        local = _prefix_product_soa(factors, carry)
        local[:, :, -1] = prefix[:, c0:c1]  # the last of a block continues the blocks' own prefix
        out = np.empty((4, stop - start))
        lo = start
        if start == 0:
            out[:, 0] = _IDENTITY
            lo = 1
        if stop > lo:
            flat = local.reshape(4, -1)
            out[:, lo - start :] = flat[:, lo - 1 - c0 * BLOCK : stop - 1 - c0 * BLOCK]
        return out

    def block(self, m: int, start: int, stop: int) -> np.ndarray:
        """``A_j`` (stop − start, 3, 3) of samples ``start … stop − 1`` of interval ``m``."""
        item = self.items[m]
        if item is None:
            item = self._short(m)
        if item is not None:
            return item[start:stop]
        return _weighted_rotations_soa(self.attitudes(m, start, stop), self.integrator._trapezoid(m)[start:stop])


def five_point_derivative(x: np.ndarray, dt: float) -> np.ndarray:
    """Time derivative by the five-point stencil (Zhang 2021, eq. 20).

    ``ẋ_k = (x_{k-2} − 8x_{k-1} + 8x_{k+1} − x_{k+2}) / (12·dt)``; the two
    samples at each end use second-order one-sided/central differences.

    Parameters
    ----------
    x : (N, ...) array_like
        Uniformly sampled signal.
    dt : float
        Sample interval [s].
    """
    x = np.asarray(x, dtype=np.float64)
    if x.shape[0] < 5:
        raise ValueError(f"the five-point derivative needs at least 5 samples; got {x.shape[0]}")
    return segmented_five_point(x, np.array([0]), np.array([x.shape[0]]), dt)


def segmented_five_point(x: np.ndarray, starts: np.ndarray, stops: np.ndarray, dt: float) -> np.ndarray:
    """Five-point derivative (Zhang 2021, eq. 20) within each segment ``[start, stop)``.

    The segments are consecutive rows of ``x`` (N, ...); the two samples at each
    segment end use second-order one-sided/central differences.
    """
    d = np.empty_like(x)
    inner = d[2:-2]  # eq. (20), built in place: (x₋₂ − 8x₋₁ + 8x₊₁ − x₊₂) / (12 dt)
    np.subtract(x[3:-1], x[1:-3], out=inner)
    inner *= 8.0
    inner += x[:-4]
    inner -= x[4:]
    inner *= 1.0 / (12 * dt)
    a, b = np.asarray(starts), np.asarray(stops)
    d[a] = (-3 * x[a] + 4 * x[a + 1] - x[a + 2]) / (2 * dt)
    d[a + 1] = (x[a + 2] - x[a]) / (2 * dt)
    d[b - 2] = (x[b - 1] - x[b - 3]) / (2 * dt)
    d[b - 1] = (3 * x[b - 1] - 4 * x[b - 2] + x[b - 3]) / (2 * dt)
    return d
