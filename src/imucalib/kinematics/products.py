"""RK4 step factors and their ordered (tree and prefix) products; the integration of rate sequences.

The method is the module docstring's of :mod:`imucalib.kinematics`: quaternions stored component-first
(``(4, ...)``) where many are multiplied at once.
"""

from __future__ import annotations

import functools
from collections.abc import Iterator

import numpy as np

from .quaternions import IDENTITY, quat_multiply, quat_normalize

#: quaternions turned into weighted rotation matrices at a time (:func:`weighted_rotations_soa`)
ROTATION_CHUNK = 1 << 12



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
    # the Hamilton product ⊗ of (Q1)
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


def weighted_rotations_soa(q: np.ndarray, weight: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
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
        for i, j, u, op, v in entries:  # Zhang 2021, eq. (13): each entry times its weight, written once into its place
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


def rk4_constants(h: np.ndarray | float) -> tuple:
    """The factors of :func:`rk4_soa` that depend on the step lengths only: ``−h/2``, ``h/2``, ``h²/4``,
    ``h²/2``, ``h/6`` (formed as it forms them; an integrator keeps them for its steps)."""
    hh = np.multiply(h, h)
    return np.multiply(-0.5, h), np.multiply(0.5, h), 0.25 * hh, 0.5 * hh, np.divide(h, 6.0)


def rk4_soa(w0: np.ndarray, w1: np.ndarray, h: np.ndarray | float, constants: tuple | None = None) -> np.ndarray:
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
    as much as the arithmetic. ``constants``: :func:`rk4_constants` of ``h``
    when formed already.
    """
    if np.ndim(w0) == 1:  # one step: as a sequence of one (the buffers need arrays)
        return rk4_soa(np.reshape(w0, (3, 1)), np.reshape(w1, (3, 1)), np.reshape(h, (-1,)))[:, 0]
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
    minus_half, half, quarter, half_hh, sixth = rk4_constants(h) if constants is None else constants
    k3s = mul(minus_half, bb)  # eq. (Q2): K3: −h/2 B·B
    k2s = mul(minus_half, ab)  # eq. (Q2): K2: −h/2 A·B
    k2v = mul(half, axb)
    k2v += b
    k3v = mul(quarter, ab)
    np.subtract(1.0, k3v, out=k3v)
    k3v = k3v * b
    cross = _cross_into(axb, b, np.empty((3, *shape)), t)
    cross *= quarter
    k3v += cross
    v = mul(h, k3v)  # eq. (Q2): K4
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
    np.add(1.0, k2s, out=out[0])  # eq. (Q3): S_k
    a += mul(2.0, k2v, out=k2v)
    a += mul(2.0, k3v, out=k3v)
    a += k4v
    mul(sixth, a, out=out[1:])  # eq. (Q3): S_k
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
    s = rk4_soa(np.moveaxis(w0, -1, 0), np.moveaxis(w1, -1, 0), h)  # eqs. (Q2), (Q3)
    return np.moveaxis(s, 0, -1)


def tree_product_soa(f: np.ndarray) -> np.ndarray:
    """Ordered product along the last axis of (4, ..., L) component-first quaternions."""
    while f.shape[-1] > 1:
        if f.shape[-1] % 2:
            pad = np.zeros(f.shape[:-1] + (1,))
            pad[0] = 1.0
            f = np.concatenate([f, pad], axis=-1)
        f = _qmul_soa(f[..., 0::2], f[..., 1::2])
    return f[..., 0]


@functools.lru_cache(maxsize=64)
def bit_reversal(width: int) -> np.ndarray:
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


def tree_products_halves(fs: list[np.ndarray], levels: list[np.ndarray] | None = None) -> np.ndarray:
    """:func:`tree_product_soa` of each (4, W_i, m_i) stored in :func:`bit_reversal` order along axis 1
    (widths powers of two, widest first), (4, rows of all of them) in that order.

    Each level multiplies the first half by the second, contiguous blocks, the
    same pairs in the same order as the interleaved reduction (the same
    numbers); the widest are reduced alone until they are as narrow as the
    next ones, then both go on together. ``levels``, when given, receives each
    level's products, widest first: the pairs :func:`prefix_products_halves`
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


def prefix_product_soa(f: np.ndarray, carry: np.ndarray | None = None) -> np.ndarray:
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
    pairs = prefix_product_soa(_qmul_soa(f[..., 0::2], f[..., 1::2]), carry)
    out = np.empty_like(f)
    out[..., 1::2] = pairs
    out[..., 0] = f[..., 0] if carry is None else _qmul_soa(carry, f[..., 0])
    out[..., 2::2] = _qmul_soa(pairs[..., :-1], f[..., 2::2])
    return out


def prefix_products_halves(fs: list[np.ndarray], levels: Iterator[np.ndarray] | None = None) -> list[np.ndarray]:
    """:func:`prefix_product_soa` of each (4, W_i, m_i) stored in :func:`bit_reversal` order along axis 1
    (widths powers of two, widest first), returned in the same order.

    The work-efficient recursion on bit-reversed storage: the even positions
    are the first half and the odd ones the second, so the pairwise products
    are one product of contiguous halves (as :func:`tree_products_halves`);
    the prefix of the pairs gives every odd position as it is, and each even
    position ``i ≥ 2`` is the pair prefix ``i/2 − 1`` times its own factor,
    the pair prefixes moved to those places by one gather. The widest are
    paired alone until they are as narrow as the next ones, then both go on
    together: every product is the one the interleaved recursion forms (the
    same numbers), on contiguous blocks. ``levels``: the pairs of every level,
    widest first, when :func:`tree_products_halves` has formed them from the
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
        pairs, *inner = prefix_products_halves([_qmul_soa(even, odd) if levels is None else next(levels), *rest],
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
    (of pair 0 for ``j = 0``, a place :func:`prefix_products_halves` overwrites)."""
    order = bit_reversal(half)
    out = order[np.maximum(order - 1, 0)]
    out.flags.writeable = False  # shared by every caller
    return out


def _tree_product(f: np.ndarray) -> np.ndarray:
    """Ordered product along axis -2 of (..., L, 4)."""
    return np.moveaxis(tree_product_soa(np.moveaxis(f, -1, 0)), 0, -1)


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
    q0 = IDENTITY if q0 is None else quat_normalize(q0)
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
        s[invalid] = IDENTITY
    return quat_normalize(_tree_product(s))
