"""Time derivatives of sampled signals by the five-point stencil."""

from __future__ import annotations

import numpy as np


def five_point_derivative(x: np.ndarray, dt: float) -> np.ndarray:
    r"""Time derivative by the five-point stencil (Zhang 2021, eq. 20).

    .. math::

        \dot x_k = \frac{x_{k-2}}{12\Delta t} - \frac{2 x_{k-1}}{3\Delta t}
        + \frac{2 x_{k+1}}{3\Delta t} - \frac{x_{k+2}}{12\Delta t} \qquad (20)

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
