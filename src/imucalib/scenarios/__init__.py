"""Simulated sessions with known truth.

``session(name, rng=seed, ...)`` simulates one of :data:`SCENARIOS`; each
scenario lives in its own module (``zhang2021``, ``handheld``, ``qureshi2017``,
``ferraris``, ``wang2019``) with its truth. The simulators sit below the methods and import none of
them; the papers' experiments that run a method on these sessions are :mod:`imucalib.experiments`.
Methods never import from here: a session hands its layout to a method through ordinary keyword
options (:meth:`Session.method_options`). The session records and their directory format are
:mod:`imucalib.sessions`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..calibration import Calibration
from . import handheld, zhang2021
from .base import (
    DEFAULT_NOISE,
    Session,
    TossSequence,
    attitude_with_up,
    pose_session,
    read_session,
    turns_between,
    write_session,
)
from .disturb import in_blocks, with_tap
from .ferraris import ferraris_session
from .qureshi2017 import qureshi_orientations, qureshi_session, qureshi_truth, qureshi_validation
from .zhang2021 import random_truth, table1_truth

__all__ = ["DEFAULT_NOISE", "SCENARIOS", "Session", "TossSequence", "attitude_with_up", "ferraris_session",
           "in_blocks", "pose_session", "qureshi_orientations", "qureshi_session", "qureshi_truth",
           "qureshi_validation", "random_truth", "read_session", "session", "table1_truth", "turns_between", "with_tap",
           "write_session"]

#: scenario name → generator(rng, *, truth, noise, **options) → dict of Session fields
SCENARIOS: dict[str, Callable[..., dict]] = {"zhang2021": zhang2021.generate, "handheld": handheld.generate}


def session(scenario: str = "zhang2021", *, rng=None, truth: Calibration | None = None,
            noise=None, **options) -> Session:
    """Simulate a session.

    Parameters
    ----------
    scenario : str
        One of :data:`SCENARIOS`.
    rng : int or numpy.random.Generator
        Seed or generator; the same seed gives the same session.
    truth : Calibration, optional
        True parameters (default: the scenario's, e.g. Zhang 2021 Table I).
    noise : dict or float, optional
        ``{"accelerometer": σ_a [m/s²], "gyroscope": σ_g [rad/s]}`` per sample
        (default :data:`DEFAULT_NOISE`; 0 for noise-free).
    **options
        Scenario options (counts, durations, ``rate``, ``full_scale`` and
        ``lsb`` dicts in raw units for saturation and quantisation).

    Returns
    -------
    Session
        The recording, its segments (static, rotation, weightless), the truth, and the test tosses where the
        scenario has them.

    Examples
    --------
    >>> from imucalib.scenarios import session
    >>> sim = session("handheld", rng=1)
    >>> sim.recording.acc_unit, sim.truth.gravity > 9.7
    ('counts', True)
    """
    try:
        gen = SCENARIOS[scenario]
    except KeyError:
        raise ValueError(f"unknown scenario {scenario!r}; choose one of {', '.join(SCENARIOS)}") from None
    seed = rng if isinstance(rng, int | np.integer) else None
    fields = gen(np.random.default_rng(rng), truth=truth, noise=noise, **options)
    return Session(scenario=scenario, seed=None if seed is None else int(seed), **fields)


