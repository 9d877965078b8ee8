"""What the poses and the motions between them hold: the six faces, turns about one axis, saturated samples,
spikes, unsteady poses and the rotations the gyroscope's fit cannot trust."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fit.accelerometer import fit_determined, fit_sphere
from ..fit.gyroscope import MIN_POSES
from ..metrics import interval_means, transition_bounds
from ..models import TriadModel
from ..presets import STILL_WINDOW
from ..recording import STANDARD_GRAVITY, Interval, Recording
from .windows import BLOCK, SCREEN_MARGIN, pose_means, runs

__all__ = ["EDGE_TILT_DEG", "FACE_NAMES", "Turn", "find_faces", "find_turns", "no_usable_rotations", "pose_scatter",
           "saturated", "spikes", "unreliable_transitions", "unsteady_poses"]


#: the six faces in the order :func:`find_faces` returns them
FACE_NAMES = ("+x", "+y", "+z", "-x", "-y", "-z")


def find_faces(raw_means: np.ndarray, gravity: float, *, max_tilt: float = 15.0) -> np.ndarray:
    """Indices of the poses nearest to +x, +y, +z, −x, −y, −z.

    Each pose's direction is taken from the centre of the raw means (the sphere fitted through them, or
    their mean for fewer than four) and matched to the six axis directions.

    Parameters
    ----------
    raw_means : ndarray of shape (M, 3)
        The static poses' mean accelerometer readings (raw units), M ≥ 6.
    gravity : float
        Local gravity, in the units the sphere's radius is fitted in (:func:`imucalib.fit.accelerometer.fit_sphere`).
    max_tilt : float
        The largest angle [°] between a pose and the face it stands for.

    Returns
    -------
    ndarray of int, shape (6,)
        The rows of ``raw_means`` for +x, +y, +z, −x, −y, −z.

    Raises
    ------
    ValueError
        Fewer than six poses, or a face with no pose within ``max_tilt`` of it (named, with how far the
        nearest is).

    Examples
    --------
    >>> import numpy as np
    >>> from imucalib.segment import find_faces
    >>> means = 9.81 * np.array([[-1, 0, 0], [1, 0, 0], [0, -1, 0], [0, 1, 0],
    ...                          [0, 0, -1], [0, 0, 1.0]])
    >>> find_faces(means, 9.81)
    array([1, 3, 5, 0, 2, 4])
    """
    if raw_means.shape[0] < 6:
        raise ValueError(f"this method needs the six faces as static poses; got {raw_means.shape[0]} poses")
    centre = fit_sphere(raw_means, gravity).bias if raw_means.shape[0] >= 4 else raw_means.mean(axis=0)
    d = raw_means - centre
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    targets = np.vstack([np.eye(3), -np.eye(3)])
    cos = d @ targets.T  # (M, 6)
    best = np.argmax(cos, axis=0)
    tilt = np.degrees(np.arccos(np.clip(cos[best, np.arange(6)], -1, 1)))
    missing = [f"{FACE_NAMES[j]} ({tilt[j]:.0f}° off)" for j in range(6) if tilt[j] > max_tilt]
    if missing:
        raise ValueError(
            "this method needs the six faces, each axis up and down within "
            f"{max_tilt:g}° of gravity; the poses lack {', '.join(missing)}: record those faces"
        )
    return best


@dataclass(frozen=True)
class Turn:
    """A turn about one body axis between two rests in the same pose.

    ``start``/``stop`` are the samples the integration runs over (the last of
    the rest before, the first of the rest after); ``sign`` the direction of
    the raw rate about ``axis``; ``angle_deg`` its angle by the rough scale
    it was found with; ``matches`` whether that is within the tolerance of
    the known angle.
    """

    axis: int
    start: int
    stop: int
    sign: int
    angle_deg: float
    matches: bool

    def to_dict(self) -> dict:
        return {"axis": self.axis, "start": self.start, "stop": self.stop, "sign": self.sign,
                "measured_deg": self.angle_deg, "matches": self.matches}


def find_turns(recording: Recording, intervals: list[Interval], bias: np.ndarray, scale: float, *,
               angle: float = 2 * np.pi, same_pose: float = 5.0, tolerance: float = 0.2,
               min_angle: float = np.radians(45)) -> dict[int, list[Turn]]:
    """Turns by a known angle about each axis, each a chain of motions between rests in one pose.

    A hand turns a board by 360° as several quarter turns; where it pauses
    long enough the detector sees rests in between, all in the same pose (a
    turn about the vertical leaves gravity where it is). Every run of
    consecutive motions whose rests all hold one axis at the same tilt from
    gravity (within ``same_pose`` degrees, the axis within 30° of vertical) is
    a candidate, and so is each contiguous part of it; a candidate whose
    integrated raw rate ``Φ = ∫(u − b) dt`` lies along that axis (≥ 0.8 of its
    norm) turns by ``scale·|Φ|``. Per axis, the
    candidates within ``tolerance`` of ``angle`` are taken, closest first and
    without overlap; where none is, the closest one above ``min_angle`` is
    taken with ``matches=False`` so the verdict can reject the calibration
    (a 13° nudge is never a 360° turn). ``scale`` is the rough gyroscope
    scale (:func:`imucalib.fit.gyroscope.rough_scale`).
    """
    acc = interval_means(recording.acc, intervals)
    dirs = acc - np.mean(acc, axis=0)  # rough centring is enough to compare directions
    starts, stops = transition_bounds(intervals)
    raw = recording.gyro - bias
    c = np.concatenate([np.zeros((1, 3)), np.cumsum(0.5 * (raw[1:] + raw[:-1]) * np.diff(recording.t)[:, None],
                                                   axis=0)])
    u = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    candidates = set()  # (axis, first transition, last transition, angle, sign)
    for axis in range(3):
        # a turn about an axis a few degrees off vertical moves gravity round a cone about it: the rests of
        # one turn share the axis's tilt from gravity, not the gravity direction itself
        tilt = np.degrees(np.arccos(np.clip(u[:, axis], -1, 1)))  # from +axis: a flip changes it by 180°
        same = (np.abs(np.diff(tilt)) <= same_pose) & (np.minimum(tilt, 180 - tilt)[:-1] <= 30)
        for run in runs(same):
            for a in range(run.start, run.stop):
                for b in range(a, run.stop):
                    phi = c[stops[b]] - c[starts[a]]
                    i = int(np.argmax(np.abs(phi)))
                    if i != axis or abs(phi[i]) < 0.8 * np.linalg.norm(phi):  # not about this axis alone
                        continue
                    candidates.add((i, a, b, abs(scale) * abs(phi[i]), int(np.sign(phi[i]))))
    out: dict[int, list[Turn]] = {0: [], 1: [], 2: []}
    for axis in range(3):
        mine = sorted((cd for cd in candidates if cd[0] == axis), key=lambda cd: abs(cd[3] / angle - 1))
        used: set[int] = set()
        for _, a, b, ang, sign in mine:
            ok = abs(ang / angle - 1) <= tolerance
            if not ok and (out[axis] or ang < min_angle):
                continue
            if used & set(range(a, b + 1)):
                continue
            used |= set(range(a, b + 1))
            out[axis].append(Turn(axis, int(starts[a]), int(stops[b]), sign, float(np.degrees(ang)), ok))
            if not ok:
                break
    return out


def saturated(x: np.ndarray, *, run: int = 3) -> np.ndarray:
    """Samples (N,) where a channel sits at its recorded extreme for ``run`` or more samples in a row.

    A saturated sensor reports its full scale, so its clipped stretches are flat
    at the largest (or smallest) value the channel ever reads; a natural peak
    repeats its extreme value at most once or twice.
    """
    x = np.asarray(x, dtype=np.float64)
    out = np.zeros(x.shape[0], dtype=bool)
    for col in x.T:
        span = float(col.max() - col.min())
        if span <= 0:
            continue
        for extreme in (col.max(), col.min()):
            at = np.abs(col - extreme) <= 1e-9 * span
            for r in runs(at, run):
                out[r.slice] = True
    return out


def spikes(x: np.ndarray, *, factor: float = 20.0, isolation: float = 4.0) -> np.ndarray:
    """Single-sample outliers (N,): a jump out and straight back that nothing around it explains.

    Sample ``i`` is a spike on a channel when both steps ``x_i − x_{i−1}`` and
    ``x_{i+1} − x_i`` have opposite signs, exceed ``factor`` times the channel's
    median absolute step and ``isolation`` times the steps just before and after
    (``x_{i−1} − x_{i−2}``, ``x_{i+2} − x_{i+1}``: a fast but smooth turnaround of
    the hand has steps of the same size around it), and its neighbours agree with
    each other to a quarter of the jump.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    n = x.shape[0]
    out = np.zeros(n, dtype=bool)
    if n < 5:
        return out
    steps = np.diff(x.T, axis=1)  # one channel a row
    scale = np.median(np.abs(steps, out=steps), axis=1)  # the median absolute step of each channel
    scale = np.where(scale > 0, scale, np.finfo(float).tiny)
    limit = factor * scale
    for a in range(2, n - 2, BLOCK):  # samples a … b−1, each read with two neighbours either side
        b = min(a + BLOCK, n - 2)
        xb = x[a - 2:b + 2]
        d = np.diff(xb, axis=0)  # d[i + 1], d[i + 2]: the steps into and out of sample a + i
        ad = np.abs(d)
        jump = np.minimum(ad[1:-2], ad[2:-1])
        i, j = np.nonzero(jump > limit)  # the big jumps (few): the other conditions only there
        ok = ((np.sign(d[i + 1, j]) != np.sign(d[i + 2, j]))
              & (jump[i, j] > isolation * np.maximum(ad[i, j], ad[i + 3, j]))
              & (np.abs(xb[i + 3, j] - xb[i + 1, j]) < 0.25 * ad[i + 1, j]))
        out[a + i[ok]] = True
    return out


def pose_scatter(acc: np.ndarray, intervals: list[Interval]) -> np.ndarray:
    """The standard error of each pose's mean accelerometer reading (M,), in its raw unit.

    ``σ_k = sqrt(tr Cov(u) / n_k)`` over the pose's ``n_k`` samples: the noise,
    and the hand's tremor where it holds the sensor, that its mean keeps; the
    weight ``1/σ_k`` of a pose in the gravity-norm fit. A pose whose samples do
    not vary at all (quantised, noise below one count) is given the smallest
    non-zero scatter of the others (or 1).
    """
    acc = np.asarray(acc, dtype=np.float64)
    s = np.array([np.sqrt(np.sum(np.var(acc[iv.slice], axis=0)) / len(iv)) for iv in intervals])
    floor = s[s > 0].min() if np.any(s > 0) else 1.0
    return np.maximum(s, floor)


#: a pose's edges may tilt this far [deg] from its mean direction before its rotations are left out: twice the
#: verdict's acceptable gravity-direction error of the gyroscope (a hand's tremor tilts a pose's edges by 0.1-0.4°,
#: a settling hand by about 1°)
EDGE_TILT_DEG = 0.5


def unsteady_poses(recording: Recording, intervals: list[Interval], *, edge: float = STILL_WINDOW, n_sigma: float = 4.0
                   ) -> dict[int, str]:
    """Poses whose first or last ``edge`` seconds tilt away from the pose's mean direction: ``{k: why}``.

    The gyroscope's fit (Zhang 2021, eq. 14) compares the gravity direction a
    rotation ends at with the mean direction of the pose that follows, and
    starts the next rotation from that same mean: a hand that creeps or
    settles while it holds a pose makes its edges differ from its mean and
    biases every rotation that touches it. A hand's tremor scatters the
    samples about the mean but leaves the edges' means on it. So a pose is
    unsteady when the angle between the mean of its first or last ``edge``
    seconds and its mean, in the directions of the accelerometer model the
    poses determine (:func:`imucalib.fit.accelerometer.fit_determined`),
    exceeds :data:`EDGE_TILT_DEG` and ``n_sigma`` times that edge mean's own
    scatter (the pose's samples, tremor included, over √n). Its mean is
    still good for the accelerometer. Empty without a gyroscope or with fewer
    than 4 poses.

    The poses are screened together (:func:`_tilt_screen`): the model applied
    to many poses' samples at once, their sums in one pass. Only a pose whose
    screened tilt comes within :data:`SCREEN_MARGIN` of its limit is judged by
    the per-pose computation above, so the poses found and their reasons are
    those of that computation, number for number.
    """
    if recording.gyro is None or len(intervals) < 4:
        return {}
    means = pose_means(recording.acc, intervals)
    try:
        model = fit_determined(means, STANDARD_GRAVITY)[0]
    except ValueError:
        return {}
    n_edge = max(int(round(edge * recording.rate)), 2)
    tilt_floor = np.radians(EDGE_TILT_DEG)
    poses = [(k, iv) for k, iv in enumerate(intervals[1:], 1) if len(iv) >= 3 * n_edge]
    if model.is_linear and not np.any(model.g_sensitivity):  # the poses well inside the floor need no more
        near = _floor_screen(model, recording.acc, means[[k for k, _ in poses]], [iv for _, iv in poses], n_edge,
                             tilt_floor)
        poses = [p for p, check in zip(poses, near, strict=True) if check]
    near = _tilt_screen(model, recording.acc, [iv for _, iv in poses], n_edge, tilt_floor, n_sigma)
    out = {}
    for (k, iv), check in zip(poses, near, strict=True):
        if not check:
            continue
        tilts, limit = _edge_tilts(model.forward(recording.acc[iv.slice]), n_edge, tilt_floor, n_sigma)
        if max(tilts) > limit:
            where = "start" if tilts[0] > tilts[1] else "end"
            out[k] = (f"pose {k + 1} tilts {np.degrees(max(tilts)):.2g}° at its {where} from its mean (limit "
                      f"{np.degrees(limit):.2g}°: the hand moved while holding it)")
    return out


def _edge_tilts(a: np.ndarray, n_edge: int, tilt_floor: float, n_sigma: float) -> tuple[list[float], float]:
    """The tilts [rad] of a pose's first and last ``n_edge`` calibrated samples ``a`` from its mean, and the limit."""
    mean = a.mean(axis=0)
    size = np.linalg.norm(mean)
    sigma = np.sqrt(np.sum(np.var(a, axis=0)) / n_edge) / size  # [rad], the edge mean's scatter
    limit = max(tilt_floor, n_sigma * sigma)
    tilts = [float(np.arccos(min(max(float(e @ mean / (np.linalg.norm(e) * size)), -1.0), 1.0)))
             for e in (a[:n_edge].mean(axis=0), a[-n_edge:].mean(axis=0))]
    return tilts, limit


def _floor_screen(model: TriadModel, acc: np.ndarray, means: np.ndarray, poses: list[Interval], n_edge: int,
                  tilt_floor: float) -> np.ndarray:
    """Which ``poses`` may tilt at an edge beyond the floor of their limit, from their raw means: a mask (M,).

    A linear model without g-sensitivity is affine, so the calibrated mean of
    a pose or of its edge is the model applied to its raw mean (to rounding):
    the pose is steady when the larger angle between the calibrated edge means
    and pose mean is below ``(1 − SCREEN_MARGIN) × tilt_floor``, which no
    limit of :func:`_edge_tilts` is below. ``means``: the poses' raw means.
    """
    if not poses:
        return np.zeros(0, dtype=bool)
    ramp = np.arange(n_edge)
    rows = np.stack([[iv.start for iv in poses], [iv.stop - n_edge for iv in poses]], axis=1)[:, :, None] + ramp
    edges = model.forward(acc[rows.ravel()].reshape(-1, n_edge, acc.shape[1]).mean(axis=1)).reshape(len(poses), 2, -1)
    centre = model.forward(means)
    cos = np.einsum("ijk,ik->ij", edges, centre) / (np.linalg.norm(edges, axis=2)
                                                      * np.linalg.norm(centre, axis=1)[:, None])
    tilt = np.arccos(np.clip(cos, -1.0, 1.0)).max(axis=1)
    return ~(tilt < (1.0 - SCREEN_MARGIN) * tilt_floor)  # NaN: screened further


def _tilt_screen(model: TriadModel, acc: np.ndarray, poses: list[Interval], n_edge: int, tilt_floor: float,
                 n_sigma: float) -> np.ndarray:
    """Which ``poses`` may tilt at an edge (:func:`_edge_tilts`), screened many poses at a time: a mask (M,).

    The poses' samples are calibrated together, at most about :data:`BLOCK`
    at a time; each pose's first ``n_edge``, middle and last ``n_edge``
    samples are summed in one ``reduceat`` and its squared deviations from
    its mean in another. A pose is kept for the exact judgement unless its
    larger edge tilt is below ``(1 − SCREEN_MARGIN)`` × its limit.
    """
    near = np.ones(len(poses), dtype=bool)
    k = 0
    while k < len(poses):
        j, rows = k + 1, len(poses[k])
        while j < len(poses) and rows + len(poses[j]) <= BLOCK:
            rows += len(poses[j])
            j += 1
        group = poses[k:j]
        n = np.array([len(iv) for iv in group])
        first = np.concatenate([[0], np.cumsum(n)[:-1]])
        a = model.forward(np.concatenate([acc[iv.slice] for iv in group]))
        parts = np.add.reduceat(a, np.stack([first, first + n_edge, first + n - n_edge], axis=1).ravel(), axis=0)
        head, middle, tail = parts[0::3], parts[1::3], parts[2::3]
        mean = (head + middle + tail) / n[:, None]
        dev = a - np.repeat(mean, n, axis=0)
        var = np.add.reduceat(dev * dev, first, axis=0) / n[:, None]
        size = np.linalg.norm(mean, axis=1)
        limit = np.maximum(tilt_floor, n_sigma * np.sqrt(var.sum(axis=1) / n_edge) / size)
        tilt = np.zeros(len(group))
        for e in (head / n_edge, tail / n_edge):
            cos = np.einsum("ij,ij->i", e, mean) / (np.linalg.norm(e, axis=1) * size)
            tilt = np.maximum(tilt, np.arccos(np.clip(cos, -1.0, 1.0)))
        near[k:j] = ~(tilt < (1.0 - SCREEN_MARGIN) * limit)  # NaN: judged exactly
        k = j
    return near


def unreliable_transitions(recording: Recording, intervals: list[Interval], *,
                           gap_factor: float = 2.5) -> dict[int, str]:
    """Rotations between consecutive poses whose integration cannot be trusted: ``{k: why}``.

    Rotation ``k`` runs from pose ``k`` to pose ``k+1``. It is unreliable when
    it holds saturated gyroscope samples (:func:`saturated`: the rate beyond
    full scale is lost), spikes (:func:`spikes`) or a sampling gap longer than
    ``gap_factor`` × the median step (the attitude is integrated sample to
    sample, Zhang 2021 eq. 23; across a gap the rate is only interpolated).
    Such rotations are left out of the gyroscope fit, not fitted; so are the
    rotations into and out of a pose the gyroscope finds unsteady
    (:func:`unsteady_poses`): its accelerometer mean is kept, not its edges.
    """
    if len(intervals) < 2 or recording.gyro is None:
        return {}
    starts, stops = transition_bounds(intervals)
    sat = np.nonzero(saturated(recording.gyro))[0]
    spk = np.nonzero(spikes(recording.gyro))[0]
    dt = np.diff(recording.t)
    gaps = np.nonzero(dt > gap_factor * np.median(dt))[0] if dt.size else np.zeros(0, int)
    # per rotation [a, b]: the saturated samples and spikes in a … b, the gaps that start in a … b − 1 (sorted indices)
    n_sat = np.maximum(np.searchsorted(sat, stops, "right") - np.searchsorted(sat, starts, "left"), 0)
    n_spk = np.maximum(np.searchsorted(spk, stops, "right") - np.searchsorted(spk, starts, "left"), 0)
    first_gap, end_gap = np.searchsorted(gaps, starts, "left"), np.searchsorted(gaps, stops, "left")
    out = {}
    for k in np.flatnonzero(n_sat | n_spk | (end_gap > first_gap)).tolist():
        why = []
        if n_sat[k]:
            why.append(f"{n_sat[k]} saturated gyroscope sample(s)")
        if n_spk[k]:
            why.append(f"{n_spk[k]} spike(s) in the gyroscope")
        inside = gaps[first_gap[k]:end_gap[k]]
        if inside.size:
            why.append(f"{inside.size} sampling gap(s), the longest {dt[inside].max():.3g} s")
        out[k] = " and ".join(why)
    for k, why in unsteady_poses(recording, intervals).items():  # rotation k−1 ends at pose k, rotation k leaves it
        for j in (k - 1, k):
            if 0 <= j < len(starts):
                out[j] = f"{out[j]} and {why}" if j in out else why
    return out


def no_usable_rotations(intervals: list[Interval], left_out: dict[int, str]) -> str | None:
    """Why the rotations between ``intervals`` leave nothing to fit a gyroscope to, or None.

    The gyroscope fit (:func:`imucalib.fit.gyroscope.fit_gyroscope`) needs
    :data:`~imucalib.fit.gyroscope.MIN_POSES` static poses and at least one
    rotation between them that is not ``left_out`` (index ``k``: from pose
    ``k`` to ``k+1`` → why, :func:`unreliable_transitions`). Without them a
    method that calibrates both sensors calibrates the accelerometer alone and
    says why (``fit.gyroscope.not_calibrated``); a fit on a few rotations
    runs, and its verdict judges whether they determine the gyroscope.
    """
    n = max(len(intervals) - 1, 0)
    if len(intervals) < MIN_POSES:
        return (f"the gyroscope was not calibrated: {len(intervals)} static pose{'' if len(intervals) == 1 else 's'} "
                f"found, and its calibration needs at least {MIN_POSES} with rotations between them")
    if len(left_out) < n:
        return None
    k, why = min(left_out.items())
    return (f"the gyroscope was not calibrated: all {n} rotations between poses were left out as unreliable (the "
            f"first, from pose {k + 1} to {k + 2}: {why}); record again with rotations slower than the gyroscope's "
            "range, without gaps")
