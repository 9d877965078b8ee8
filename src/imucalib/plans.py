"""Pose plans for the accelerometer and what each one can determine, before anything is recorded.

A plan is a list of static poses, each given by the direction of the
specific force (gravity, pointing up) in the body frame. For the linear
model ``a = T_a K (u − b)`` (9 parameters: 3 misalignments, 3 scales,
3 biases) the gravity-norm residuals ``‖a_k‖ − g`` (Tedaldi 2014; Ru 2022,
eq. 10) have, at the nominal sensor (``T_a = I``, ``K = I``, ``b = 0``, raw in
m/s²), a Jacobian ``J`` whose Fisher information ``JᵀJ/σ²`` gives the
Cramér–Rao bound of every parameter for a per-pose noise ``σ`` of the
static means; a parameter the plan cannot determine is reported as such.

Plans:

* ``"six"`` — each axis up and down (Ru 2022, eqs. 8–9): enough for biases
  and scales, not for misalignments;
* ``"nine"`` — the six faces and three attitudes with two axes 45° up
  (Ru 2022, Table 3, the approximately optimal nine attitudes): every
  parameter, exactly;
* an integer ``N`` — ``N`` directions spread evenly over the sphere
  (a Fibonacci lattice), as a free-hand Tedaldi/Zhang session roughly does.

:func:`next_poses` turns the same bound into advice on a recording already
made: the up-directions that, added to the poses recorded, most shrink the
worst 1σ (greedy, one pose at a time); :func:`describe_direction` says one in
words ("z up", "z up tilted 45° about x towards y up").
"""

from __future__ import annotations

import functools

import numpy as np

from .constants import STANDARD_GRAVITY
from .models import TriadModel
from .residuals import AccelLayout, gravity_norm_residuals
from .solve import standard_errors

__all__ = ["plan_directions", "accelerometer_plan", "next_poses", "describe_direction", "describe_poses",
           "candidate_directions"]

_S = np.sqrt(0.5)
#: Ru 2022, Table 3: x up, x down, y up, y down, z up, z down, then (body axes' up components)
#: 7 x east, y north-up 45°, z south-up 45°; 8 y east, z north-up, x south-up; 9 z east, x north-up, y south-up
NINE = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
                 [0, _S, _S], [_S, 0, _S], [_S, _S, 0]], dtype=float)


def plan_directions(plan: str | int) -> np.ndarray:
    """The unit up-directions (body frame) of a named plan or of ``N`` evenly spread poses."""
    if plan == "six":
        return NINE[:6].copy()
    if plan == "nine":
        return NINE.copy()
    try:
        n = int(plan)
    except (TypeError, ValueError):
        raise ValueError(f"plan must be 'six', 'nine' or a number of poses; got {plan!r}") from None
    if n < 1:
        raise ValueError(f"a plan needs at least one pose; got {n}")
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5**0.5) * k  # golden-angle spiral
    r = np.sqrt(1 - z * z)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def accelerometer_plan(plan: str | int | np.ndarray, *, noise: float = 0.002,
                       gravity: float = STANDARD_GRAVITY) -> dict:
    """Cramér–Rao bounds of the linear accelerometer model's 9 parameters for a pose plan.

    Parameters
    ----------
    plan : str, int or numpy.ndarray
        ``"six"`` (the faces), ``"nine"`` (Ru 2022 Table 3), a number of evenly spread poses, or the up
        directions themselves, shape ``(n, 3)``.
    noise : float
        The standard deviation of one pose's mean [m/s²] (the sample noise divided by the square root of the
        samples held).
    gravity : float
        Local gravity [m/s²].

    Returns
    -------
    dict
        ``{"directions", "noise", "poses", "parameters": [{"parameter", "crlb_std", "observable"}, …]}``:
        ``crlb_std`` is NaN where the plan cannot determine the parameter; scales are relative (the nominal scale
        is 1), misalignments in rad, biases in m/s².

    Raises
    ------
    ValueError
        For a noise that is not a positive number, or an unknown plan.

    Examples
    --------
    >>> from imucalib.plans import accelerometer_plan
    >>> six = accelerometer_plan("six")
    >>> [p["parameter"] for p in six["parameters"] if not p["observable"]]
    ['accelerometer.misalignment.xy', 'accelerometer.misalignment.xz',
     'accelerometer.misalignment.yz']
    """
    d = plan_directions(plan) if not isinstance(plan, np.ndarray) else np.asarray(plan, dtype=float)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    if not (np.isfinite(noise) and noise > 0):
        raise ValueError(f"noise must be a positive number of m/s^2; got {noise!r}")
    layout = AccelLayout("upper", 1)
    theta = layout.pack(TriadModel(shape="upper"))
    _, jac = gravity_norm_residuals(theta, layout, gravity * d, gravity, jacobian=True)
    # the bound for residuals of standard deviation σ: standard_errors with ‖r‖²/dof = σ²
    fake = np.full(jac.shape[0], noise)
    crlb = standard_errors(jac, fake, dof=jac.shape[0])
    names = layout.names("accelerometer")
    return {"directions": d.tolist(), "noise": noise, "poses": int(d.shape[0]),
            "parameters": [{"parameter": n, "crlb_std": float(c), "observable": bool(np.isfinite(c))}
                           for n, c in zip(names, crlb, strict=True)]}


def _unit_jacobian(directions: np.ndarray) -> np.ndarray:
    """Jacobian (M, 9) of ``‖a_k‖ − 1`` for unit up-directions at the nominal sensor (gravity taken as 1).

    With gravity 1 every parameter is dimensionless: scales relative to the
    nominal 1, misalignments in rad, biases as a fraction of ``g``; the rows
    are Ru 2022's eq. (10) linearised, as in :func:`accelerometer_plan`.
    """
    layout = AccelLayout("upper", 1)
    theta = layout.pack(TriadModel(shape="upper"))
    return gravity_norm_residuals(theta, layout, np.asarray(directions, dtype=float), 1.0, jacobian=True)[1]


def candidate_directions(grid: int = 200) -> np.ndarray:
    """Candidate up-directions: the cube's 6 faces, 12 edges and 8 corners, then ``grid`` evenly spread ones."""
    cube = np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)
                     if (i, j, k) != (0, 0, 0)], dtype=float)
    order = np.argsort(np.count_nonzero(cube, axis=1), kind="stable")  # faces first, then edges, then corners
    cube = cube[order] / np.linalg.norm(cube[order], axis=1, keepdims=True)
    return np.vstack([cube, plan_directions(grid)])


@functools.cache
def _default_candidates() -> tuple[np.ndarray, np.ndarray]:
    """:func:`candidate_directions` as unit vectors and their rows of :func:`_unit_jacobian`, made once (read-only)."""
    cand = candidate_directions()
    cand = cand / np.linalg.norm(cand, axis=1, keepdims=True)
    jc = _unit_jacobian(cand)
    cand.flags.writeable = jc.flags.writeable = False
    return cand, jc


def next_poses(directions: np.ndarray, *, count: int = 3, candidates: np.ndarray | None = None,
               prior: float = 1e-9, min_separation_deg: float = 10.0, simple: float = 0.05) -> np.ndarray:
    """Up-directions to record next: those that most shrink the worst 1σ of the linear accelerometer model.

    Parameters
    ----------
    directions : (M, 3) array_like
        Up-directions (the calibrated gravity direction, body frame) of the
        poses recorded; need not be unit vectors.
    count : int
        How many poses to suggest (greedy: each chosen with those before it).
    candidates : (C, 3) array_like, optional
        Directions to choose from (default :func:`candidate_directions`).
    prior : float
        Fisher information added to every parameter (a weak prior, ``σ = 1/√prior``
        relative): an undetermined parameter gets a huge but finite 1σ, so a pose
        that determines half of an undetermined pair still counts as progress.
    min_separation_deg : float
        A candidate within this angle of one already suggested is not suggested again.
    simple : float
        A face, edge or corner of the cube is preferred to another candidate whose
        worst variance is lower by less than this fraction (it is easier to hold).

    Returns
    -------
    (count, 3) ndarray
        Unit vectors, best first.

    Notes
    -----
    Each pose adds ``j jᵀ`` to the Fisher information ``F = JᵀJ/σ²`` of the
    nine-parameter linear model's gravity-norm residuals (Ru 2022, eq. 10, as in
    :func:`accelerometer_plan`); the pose noise ``σ`` is the same for every pose
    and so leaves the ranking unchanged. The candidate chosen minimises the
    largest diagonal entry of ``(F + j jᵀ)⁻¹`` (the worst relative variance),
    with the trace breaking ties (and ``simple`` favouring the cube's
    directions); the inverse of each candidate's update comes from
    Sherman–Morrison, ``(A + j jᵀ)⁻¹ = A⁻¹ − A⁻¹j jᵀA⁻¹ / (1 + jᵀA⁻¹j)``.

    Examples
    --------
    After the four poses x up and down and z up and down, the next two to record:

    >>> import numpy as np
    >>> from imucalib.plans import next_poses
    >>> done = np.array([[0, 0, 1.0], [0, 0, -1], [1, 0, 0], [-1, 0, 0]])
    >>> next_poses(done, count=2).round(3)
    array([[-0.577, -0.577, -0.577],
           [ 0.   , -1.   ,  0.   ]])
    """
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    norms = np.linalg.norm(d, axis=1)
    d = d[np.isfinite(norms) & (norms > 0)]
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    if count < 0:
        raise ValueError(f"count must be zero or more; got {count}")
    if candidates is None:
        (cand, jc), n_cube = _default_candidates(), 26
    else:
        cand, n_cube = np.asarray(candidates, dtype=float).reshape(-1, 3), 0
        cand = cand / np.linalg.norm(cand, axis=1, keepdims=True)
        jc = _unit_jacobian(cand)
    info = prior * np.eye(jc.shape[1])
    if d.shape[0]:
        jr = _unit_jacobian(d)
        info = info + jr.T @ jr
    chosen: list[int] = []
    available = np.ones(cand.shape[0], dtype=bool)
    cos_sep = np.cos(np.radians(min_separation_deg))
    for _ in range(min(count, cand.shape[0])):
        p = np.linalg.inv(info)
        v = jc @ p  # (C, 9): A⁻¹ j per candidate (A symmetric)
        var = np.diag(p)[None, :] - v * v / (1.0 + np.einsum("ij,ij->i", v, jc))[:, None]
        worst = np.where(available, var.max(axis=1), np.inf)
        near = available & (worst <= worst.min() * (1 + simple))
        if np.any(near[:n_cube]):  # a face, edge or corner of the cube is easier to hold than an odd tilt
            near[n_cube:] = False
        k = int(np.argmin(np.where(near, var.sum(axis=1), np.inf)))
        chosen.append(k)
        info = info + np.outer(jc[k], jc[k])
        available &= cand @ cand[k] < cos_sep
        if not available.any():
            break
    return cand[chosen]


_AXES = "xyz"


def describe_direction(u, *, face_deg: float = 10.0) -> str:
    """An up-direction in words: ``"z up"``, ``"x down"``, ``"z up tilted 45° about x towards y up"``.

    The face is the body axis nearest to ``u`` (``"up"`` when it points along
    ``u``); within ``face_deg`` of it the face alone is said. Otherwise the tilt
    from that face and the axes the tilt raises (``up``) or lowers (``down``),
    with the axis it turns about when it raises or lowers one axis only; a
    corner of the cube as ``"corner with x and y up, z down"``.
    """
    u = np.asarray(u, dtype=float).reshape(3)
    n = float(np.linalg.norm(u))
    if not (np.isfinite(n) and n > 0):
        raise ValueError(f"a direction needs a finite, non-zero vector; got {u.tolist()}")
    u = u / n
    i = int(np.argmax(np.abs(u)))
    face = f"{_AXES[i]} {'up' if u[i] > 0 else 'down'}"
    tilt = float(np.degrees(np.arccos(np.clip(abs(u[i]), -1.0, 1.0))))
    if tilt <= face_deg:
        return face
    corner = np.degrees(np.arccos(np.clip(np.abs(u) @ np.full(3, 3**-0.5), -1.0, 1.0)))
    if corner <= face_deg:  # a corner of the cube: all three axes equally up or down
        ups = [_AXES[j] for j in range(3) if u[j] > 0]
        downs = [_AXES[j] for j in range(3) if u[j] < 0]
        said = [f"{_join(a)} {w}" for a, w in ((ups, "up"), (downs, "down")) if a]
        return f"corner with {' and '.join(said) if len(said) == 1 else ', '.join(said)}"
    perp = u.copy()
    perp[i] = 0.0
    perp /= np.linalg.norm(perp)
    towards = [j for j in range(3) if j != i and abs(perp[j]) > np.cos(np.radians(67.5))]
    words = " and ".join(_AXES[j] for j in towards)
    if len(towards) == 1:
        rise = "up" if perp[towards[0]] > 0 else "down"
        about = 3 - i - towards[0]
        return f"{face} tilted {tilt:.0f}° about {_AXES[about]} towards {words} {rise}"
    signs = {"up" if perp[j] > 0 else "down" for j in towards}
    if len(signs) == 1:
        return f"{face} tilted {tilt:.0f}° towards {words} {signs.pop()}"
    parts = " and ".join(f"{_AXES[j]} {'up' if perp[j] > 0 else 'down'}" for j in towards)
    return f"{face} tilted {tilt:.0f}° towards {parts}"


def _join(words: list[str]) -> str:
    """``["x", "y", "z"]`` → ``"x, y and z"``."""
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def describe_poses(directions) -> str:
    """Several up-directions in words, in order: ``"z up, then z down"``.

    Parameters
    ----------
    directions : array_like
        Up directions in the body frame, shape ``(n, 3)`` (normalised here).

    Returns
    -------
    str
        Each direction in words (:func:`describe_direction`), joined by ``", then "``.

    Examples
    --------
    >>> from imucalib.plans import describe_poses
    >>> describe_poses([[0, 0, 1], [0, 0, -1]])
    'z up, then z down'
    """
    return ", then ".join(describe_direction(u) for u in np.asarray(directions, dtype=float).reshape(-1, 3))
