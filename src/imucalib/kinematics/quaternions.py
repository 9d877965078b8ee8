"""Quaternion and rotation basics (the conventions of :mod:`imucalib.kinematics`)."""

from __future__ import annotations

import numpy as np

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def quat_multiply(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of scalar-first quaternions, broadcast over leading axes."""
    p = np.asarray(p, dtype=np.float64)
    q = np.asarray(q, dtype=np.float64)
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            # the Hamilton product ⊗ of (Q1): (p_w q_w − p·q, p_w q + q_w p + p × q)
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
    # Zhang 2021, eq. (13), entry by entry
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
    from scipy.spatial.transform import Rotation  # scipy.spatial costs 60 ms at start-up, for the conversions only

    q = np.asarray(q, dtype=np.float64)
    return Rotation.from_quat(q[..., [1, 2, 3, 0]])


def from_scipy(rotation) -> np.ndarray:
    """Scalar-first quaternions from a :class:`scipy.spatial.transform.Rotation`."""
    q = rotation.as_quat()
    return q[..., [3, 0, 1, 2]]
