"""Property tests of ``calibrate`` on generated sessions: a calibration with finite parameters, or a ValueError
in plain words; never a NaN parameter, never a numpy warning (RuntimeWarnings are errors in the suite)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is not installed")
from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from imucalib.methodinfo import accelerometer_only  # noqa: E402
from imucalib.methods import calibrate  # noqa: E402
from imucalib.recording import ImucalibWarning, Recording  # noqa: E402
from synth import linear_truth, tedaldi_session  # noqa: E402

METHODS = accelerometer_only()  # the methods that take an accelerometer-only recording


def _outcome(data, method, **options):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        try:
            return calibrate(data, method=method, **options)
        except ValueError as exc:
            return exc


def _check(result) -> None:
    if isinstance(result, ValueError):
        text = str(result)
        assert text and "np." not in text and "numpy" not in text and "dtype" not in text, text
        return
    values = np.array(list(result.parameters().values()))
    assert np.all(np.isfinite(values)), result.parameters()
    for key, value in result.fit.items():
        if isinstance(value, float):
            assert np.isfinite(value) or key.endswith(("_deg", "_rms")), (key, value)  # figures may be unknown


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**16), poses=st.integers(3, 30), noise=st.floats(0.002, 0.2),
       scale=st.floats(0.5, 2.0), bias=st.floats(-500, 500), method=st.sampled_from(METHODS))
def test_calibrate_on_generated_sessions(seed, poses, noise, scale, bias, method):
    truth = linear_truth()
    truth = truth.with_(accelerometer=truth.accelerometer.with_(scale=truth.accelerometer.scale * scale,
                                                                bias=truth.accelerometer.bias + bias))
    rec, _, _ = tedaldi_session(truth, seed=seed, poses=poses, noise_acc=noise, noise_gyro=noise / 10)
    result = _outcome(rec, method)
    _check(result)
    if not isinstance(result, ValueError) and poses >= 20 and noise < 0.02 and method == "tedaldi2014":
        np.testing.assert_allclose(result.accelerometer.scale, truth.accelerometer.scale, rtol=0.02)


@settings(max_examples=25, deadline=None)
@given(kind=st.sampled_from(["noise", "constant", "short", "spikes", "steps", "huge"]), seed=st.integers(0, 999),
       method=st.sampled_from(METHODS))
def test_calibrate_on_recordings_that_are_no_session(kind, seed, method):
    rng = np.random.default_rng(seed)
    n = 30 if kind == "short" else 3000
    t = np.arange(n) * 0.01
    acc = rng.normal([0, 0, 2048], 3, (n, 3))
    gyro = rng.normal(0, 2, (n, 3))
    if kind == "noise":
        acc, gyro = rng.normal(0, 1000, (n, 3)), rng.normal(0, 1000, (n, 3))
    elif kind == "constant":
        acc, gyro = np.full((n, 3), 5.0), np.zeros((n, 3))
    elif kind == "spikes":
        acc[rng.integers(0, n, 50)] *= 1e6
    elif kind == "steps":
        acc = np.repeat(rng.normal(0, 2048, (n // 300, 3)), 300, axis=0)
    elif kind == "huge":
        acc, gyro = acc * 1e12, gyro * 1e12
    _check(_outcome(Recording(t, acc, gyro), method))
