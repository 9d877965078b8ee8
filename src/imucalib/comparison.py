"""Run every calibration method a recording supports and compare them out of sample.

Each method is calibrated on the same static intervals (detected once by the
Tedaldi 2014 detector) and judged by leave-one-pose-out cross-validation
(:mod:`imucalib.crossval`): the held-out gravity residual and gyroscope angle
error. Methods that cannot run on the data report why.

The methods are ranked (:func:`rank`) by, in turn:

1. whether the method ran on the data (those that cannot run come last);
2. the verdict of its calibration on all poses (:mod:`imucalib.verdict`):
   accepted, then suspect (or none), then rejected;
3. the cross-validated score ``r/r_best + θ/θ_best``: the held-out gravity
   residual RMS ``r`` and mean gyroscope angle error ``θ``, each relative to the
   best value any method reached on this recording (a method best on both scores 2);
   ``r/r_best`` alone for an accelerometer-only recording, which compares the
   methods that take one.

The best method is the first one that ran and was not rejected (none when
every method was rejected or could not run, or when two or more share the
first place with the same verdict and score: a tie, said as such). Each method
runs with the model its ``calibrate`` takes by default. Where a method selects
its model variant (zhang2021 without tosses), the method's own selection runs
once on all poses — the variant ``imucalib calibrate`` selects on the same
recording — and the folds refit it: ten times faster, slightly optimistic for
that one choice.

A calibration made elsewhere (another tool's, or an earlier imucalib file) can
be set beside them (``peers``): it is not refitted, only scored on the same
held-out poses by the same figures. It is not ranked: unless it was made from
another recording, it was fitted to those poses, so its figures are in sample
and flatter it.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from functools import partial

import numpy as np

from .constants import STANDARD_GRAVITY
from .crossval import leave_one_pose_out
from .methods import ACCELEROMETER_ONLY, calibrate, method_names
from .presets import MIN_HOLD
from .recording import ImucalibWarning, Interval, Recording
from .segment import detect_intervals

__all__ = ["DEFAULT_MODELS", "RANKED_BY", "compare", "even_folds", "rank", "tied_best"]

#: the model each method is compared with where it differs from the one ``calibrate`` takes by default (none does:
#: ``compare`` and ``calibrate`` select the same variant on the same recording)
DEFAULT_MODELS: dict[str, str | None] = {}


#: the ranking in words (the module docstring has it in full), for the JSON and the table
RANKED_BY = ("methods that ran, then verdict (accepted, suspect, rejected), then the cross-validated score "
             "r/r_best + angle/angle_best (held-out |a|-g RMS and gyroscope angle error, each relative to the best "
             "method's)")

_VERDICT_ORDER = {"accepted": 0, "suspect": 1, None: 1, "rejected": 2}


def rank(rows: Sequence[dict]) -> tuple[list[dict], str | None]:
    """The rows ranked as the module docstring says, each with its ``rank`` and ``score``; and the best method.

    ``rows`` are :func:`compare`'s, with ``ok``, ``verdict`` and the two cross-validated figures.
    Rows equal in all of these share a rank; when the best place is shared
    the best method is None and the tied rows carry ``tied: True``
    (:func:`tied_best`): nothing in the figures prefers one of them.
    """
    def figure(row, key):
        v = row.get(key)
        return v if row.get("ok") and v is not None and np.isfinite(v) else None

    best = {}
    for key in ("cv_accelerometer_residual_rms", "cv_gyroscope_angle_error_mean_deg"):
        values = [v for v in (figure(r, key) for r in rows) if v is not None]
        best[key] = max(min(values), 1e-300) if values else None
    best = {k: v for k, v in best.items() if v is not None}  # no angle without a gyroscope: the residual alone
    out = []
    for row in rows:
        parts = [figure(row, key) for key in best]
        score = (sum(v / best[key] for v, key in zip(parts, best, strict=True))
                 if row.get("ok") and all(v is not None for v in parts) else None)
        out.append({**row, "score": score})
    def key(r):
        return (not r.get("ok"), _VERDICT_ORDER.get(r.get("verdict"), 1), np.inf if r["score"] is None else r["score"])

    def same(a, b):  # equal in every ranked figure: no order between them
        ka, kb = key(a), key(b)
        return ka[:2] == kb[:2] and (ka[2] == kb[2] or bool(np.isclose(ka[2], kb[2], rtol=1e-9, atol=0)))

    out.sort(key=key)
    for i, row in enumerate(out, 1):  # tied rows share the rank of the first of them
        row["rank"] = out[i - 2]["rank"] if i > 1 and same(row, out[i - 2]) else i
    first = next((r for r in out if r.get("ok") and r.get("verdict") != "rejected"), None)
    if first is None:
        return out, None
    tied = [r for r in out if r is not first and same(r, first)]
    for r in (first, *tied) if tied else ():
        r["tied"] = True
    return out, None if tied else first["method"]


def tied_best(ranked: Sequence[dict]) -> list[str]:
    """The methods tied for the best place of :func:`rank` (the same verdict and score); empty without a tie."""
    return [r["method"] for r in ranked if r.get("tied")]


def even_folds(n_intervals: int, count: int | None) -> list[int]:
    """``count`` held-out poses spread evenly over 1…n−1 (all when ``count`` is None)."""
    poses = np.arange(1, n_intervals)
    if count is None or count >= poses.size:
        return poses.tolist()
    pick = np.unique(np.round(np.linspace(0, poses.size - 1, count)).astype(int))
    return poses[pick].tolist()


def compare(
    recording: Recording,
    *,
    gravity: float = STANDARD_GRAVITY,
    methods: Sequence[str] | None = None,
    intervals: Sequence[Interval] | None = None,
    folds: int | None = 12,
    progress: Callable[[str], None] | None = None,
    init_static: float | None = None,
    peers: Mapping[str, object] | None = None,
    magnetometer: bool = True,
    min_hold: float = MIN_HOLD,
) -> dict:
    """Calibrate with each method and cross-validate it.

    Parameters
    ----------
    recording : Recording
        Raw readings: an initial rest, static poses and rotations.
    gravity : float
        Local gravity [m/s²].
    methods : sequence of str, optional
        Methods to try (default: every registered method).
    intervals : sequence of Interval, optional
        Static intervals; detected by the Tedaldi 2014 detector by default.
    folds : int or None
        Number of held-out poses, spread evenly (None: every pose).
    progress : callable, optional
        Called with a message per method.
    init_static : float, optional
        Length of the initial rest [s] (found automatically by default,
        :func:`imucalib.segment.initial_rest`).
    peers : mapping of str to Calibration, optional
        Calibrations made elsewhere, by name, scored on the same held-out
        poses without refitting (module docstring).
    magnetometer : bool
        Calibrate the recording's magnetometer (if it has one) in each method's calibration on all poses
        (its figures then enter the row's ``fit`` and its verdict); False leaves it out. The folds never
        calibrate it: the cross-validated figures judge the accelerometer and the gyroscope only.
    min_hold : float
        The shortest hold that is a pose [s] (:func:`imucalib.presets.hold_settings`).

    Returns
    -------
    dict
        With the keys:

        * ``static_intervals`` (int), ``folds`` (int): the poses found and the folds they were cut into;
        * ``best`` (str or None): the best method, None when two or more are tied for the best place;
        * ``tied`` (list of str): the methods tied for the best place;
        * ``ranked_by`` (str): how the methods are ranked, in words;
        * ``methods`` (list of dict): one per method, in the order of :func:`rank`, with ``rank``,
          ``method``, ``model``, ``ok``, ``reason``, ``verdict``, ``score``,
          ``cv_accelerometer_residual_rms``, ``cv_gyroscope_angle_error_mean_deg`` and ``fit``;
        * ``peers`` (list of dict): one per peer calibration, in the order given (empty without them),
          with ``name``, ``ok``, ``reason``, ``cv_accelerometer_residual_rms`` and
          ``cv_gyroscope_angle_error_mean_deg``.

    Examples
    --------
    Two methods on a short simulated session, cross-validated over 3 folds of its poses:

    >>> from imucalib.comparison import compare
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1, rest=10, n_poses=14)
    >>> found = compare(sim.recording, gravity=sim.truth.gravity,
    ...                 methods=["tedaldi2014", "ellipsoid"], folds=3)
    >>> found["best"], [(m["method"], m["rank"], m["verdict"]) for m in found["methods"]]
    ('tedaldi2014', [('tedaldi2014', 1, 'accepted'), ('ellipsoid', 2, 'accepted')])
    """
    say = progress or (lambda msg: None)
    if intervals is None:
        intervals = detect_intervals(recording, gravity, init_static=init_static, min_hold=min_hold)[0]
    intervals = list(intervals)
    chosen = list(methods) if methods is not None else method_names()
    if recording.gyro is None and methods is None:  # an accelerometer-only recording: the methods that take it
        chosen = [m for m in chosen if m in ACCELEROMETER_ONLY]
    fold_list = even_folds(len(intervals), folds)
    rows = [_method_row(recording, intervals, fold_list, name, gravity, magnetometer, say) for name in chosen]
    ranked, best = rank(rows)
    return {"static_intervals": len(intervals), "folds": len(fold_list), "best": best, "tied": tied_best(ranked),
            "ranked_by": RANKED_BY, "methods": ranked,
            "peers": [_score_peer(recording, intervals, fold_list, name, cal, gravity)
                      for name, cal in (peers or {}).items()]}


def _method_row(recording: Recording, intervals: list[Interval], fold_list: list[int], name: str, gravity: float,
                magnetometer: bool, say: Callable[[str], None]) -> dict:
    """One method's row of :func:`compare`: its calibration on all poses, then cross-validated on ``fold_list``
    (``ok`` False and the ``reason`` when it cannot calibrate the recording)."""
    model = DEFAULT_MODELS.get(name)
    row = {"method": name, "model": model, "ok": False, "reason": None, "verdict": None,
           "cv_accelerometer_residual_rms": None, "cv_gyroscope_angle_error_mean_deg": None}
    say(f"{name}: calibrating")

    def fit(training, name=name, model=model, extra=None, magnetometer=False):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ImucalibWarning)
            return calibrate(recording, method=name, model=model, gravity=gravity,
                             intervals=training, magnetometer=magnetometer, **(extra or {}))

    try:
        full = fit(intervals, magnetometer=magnetometer)
        sel = full.fit.method.model_selection
        row["model"] = model or (sel["requested"] if sel else full.model)
        if sel:
            # the variant is chosen once on all poses; the folds refit that variant
            row["model_selected"] = sel["selected"]
            fit = partial(fit, model=sel["selected"], extra={"select": False})
        row["fit"] = {k: v for k, v in full.fit.to_flat().items() if isinstance(v, int | float)}
        row["verdict"] = full.fit.verdict.level
        say(f"{name}: cross-validating on {len(fold_list)} held-out poses")
        cv = leave_one_pose_out(recording, intervals, fit, gravity=gravity, folds=fold_list)
    except (ValueError, np.linalg.LinAlgError) as exc:
        row["reason"] = str(exc)
        return row
    row.update(ok=True, cv_accelerometer_residual_rms=cv["cv_accelerometer_residual_rms"],
               cv_gyroscope_angle_error_mean_deg=cv["cv_gyroscope_angle_error_mean_deg"],
               cv_folds=cv["folds"], cv_folds_skipped=len(cv["folds_skipped"]))
    return row


def _score_peer(recording: Recording, intervals: list[Interval], folds: list[int], name: str, calibration,
                gravity: float) -> dict:
    """A calibration made elsewhere scored on the held-out poses as it is (no refit; module docstring)."""
    row = {"name": name, "ok": False, "reason": None, "cv_accelerometer_residual_rms": None,
           "cv_gyroscope_angle_error_mean_deg": None}
    try:
        calibration.check_units(recording)
        cv = leave_one_pose_out(recording, intervals, lambda training: calibration, gravity=gravity, folds=folds)
    except ValueError as exc:
        return {**row, "reason": str(exc)}
    return {**row, "ok": True, "cv_accelerometer_residual_rms": cv["cv_accelerometer_residual_rms"],
            "cv_gyroscope_angle_error_mean_deg": cv["cv_gyroscope_angle_error_mean_deg"]}
