"""Property tests of the model family and of Recording construction.

* ``TriadModel.inverse`` undoes ``forward`` (and the reverse) for any
  parameters of the canonical model (Zhang 2021, eqs. 1-8 and 31-32), to a
  tolerance in raw units, or refuses with :class:`NotInvertibleError` (a
  ValueError) where the scale polynomial is not monotonic;
* a calibration file written by ``save`` reads back to the same parameters;
* ``Recording`` takes any finite, strictly time-ordered (N, 3) arrays and
  refuses anything else with a ValueError in plain words.
"""

from __future__ import annotations

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis", reason="the test extra (hypothesis) is not installed")
from hypothesis import HealthCheck, assume, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402
from hypothesis.extra import numpy as hnp  # noqa: E402

from imucalib.calibration import Calibration, CalibrationFileError  # noqa: E402
from imucalib.models import MISALIGNMENT_SHAPES, NotInvertibleError, TriadModel  # noqa: E402
from imucalib.recording import Recording  # noqa: E402

SETTINGS = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


def vec(lo, hi):
    return st.lists(st.floats(lo, hi, allow_nan=False), min_size=3, max_size=3)


@st.composite
def triad(draw, linear: bool | None = None, g: bool = True) -> TriadModel:
    shape = draw(st.sampled_from(sorted(MISALIGNMENT_SHAPES)))
    t = np.eye(3)
    for i, j in MISALIGNMENT_SHAPES[shape]:
        t[i, j] = draw(st.floats(-0.1, 0.1))
    sign = np.array(draw(st.lists(st.sampled_from([-1.0, 1.0]), min_size=3, max_size=3)))
    scale = sign * np.array(draw(vec(1e-4, 10.0)))
    nonlinear = draw(st.booleans()) if linear is None else not linear
    k2 = np.array(draw(vec(-0.05, 0.05))) * np.abs(scale) if nonlinear else np.zeros(3)
    k3 = np.array(draw(vec(0.0, 0.05))) * scale if nonlinear else np.zeros(3)
    return TriadModel(misalignment=t, scale=scale, scale_quadratic=k2, scale_cubic=k3,
                      bias=draw(vec(-50.0, 50.0)),
                      g_sensitivity=np.array(draw(vec(-1e-3, 1e-3)) * 3).reshape(3, 3) if g else np.zeros((3, 3)),
                      shape=shape)


RAW = hnp.arrays(np.float64, st.tuples(st.integers(1, 20), st.just(3)), elements=st.floats(-2.0, 2.0))


@SETTINGS
@given(triad(), RAW, hnp.arrays(np.float64, (1, 3), elements=st.floats(-20, 20)))
def test_inverse_undoes_forward(model, raw, force):
    raw = raw + model.bias
    f = np.repeat(force, raw.shape[0], axis=0)
    si = model.forward(raw, f)
    assert np.all(np.isfinite(si))
    try:
        back = model.inverse(si, f)
    except NotInvertibleError as exc:
        assert isinstance(exc, ValueError) and "np." not in str(exc) and "monotonic" in str(exc) or "Newton" in str(exc)
        return
    # Eqs. 31-32: exact inverse, to rounding amplified by the polynomial's slope at the point
    slope = np.min(np.abs(model.polynomial_derivative(raw - model.bias)))
    assume(slope > 1e-6)
    tol = 1e-9 * (1 + np.abs(si).max()) / slope + 1e-9 * (1 + np.abs(raw).max())
    np.testing.assert_allclose(back, raw, rtol=0, atol=tol)


@SETTINGS
@given(triad(linear=True, g=False), hnp.arrays(np.float64, (5, 3), elements=st.floats(-50, 50)))
def test_a_linear_model_round_trips_from_si(model, si):
    np.testing.assert_allclose(model.forward(model.inverse(si)), si, rtol=1e-9, atol=1e-9 * (1 + np.abs(si).max()))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(triad(g=False), triad(), st.floats(9.7, 9.9), st.one_of(st.none(), vec(-0.2, 0.2)))
def test_a_saved_calibration_reads_back(tmp_path, acc, gyro, gravity, lever):
    acc = acc.with_(shape="upper", misalignment=np.triu(acc.misalignment))
    cal = Calibration(accelerometer=acc, gyroscope=gyro, gravity=gravity, lever_arm=lever, method="m")
    cal.save(tmp_path / "c.json")
    # counts span what k1 maps to 16 g and 2000 deg/s; nonlinear terms beyond 1000 g / 1000 rad/s there are
    # refused on loading (calibration.check_magnitudes), and only they
    beyond = [f"{name}.{key}" for name, m, top, full in (("accelerometer", acc, 16 * 9.80665, 1e4),
                                                         ("gyroscope", gyro, np.radians(2000), 1e3))
              for key, k, p in (("scale_quadratic", m.scale_quadratic, 2), ("scale_cubic", m.scale_cubic, 3))
              if np.any(np.abs(k) * (top / np.abs(m.scale)) ** p > full)]
    if beyond:
        with pytest.raises(CalibrationFileError, match=f"'({'|'.join(beyond)})'"):
            Calibration.load(tmp_path / "c.json")
        return
    back = Calibration.load(tmp_path / "c.json")
    assert back.parameters() == cal.parameters()
    assert back.gravity == cal.gravity


@SETTINGS
@given(st.integers(0, 30), st.data())
def test_recording_takes_valid_arrays_and_refuses_the_rest_in_words(n, data):
    floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
    t = data.draw(hnp.arrays(np.float64, data.draw(st.sampled_from([(n,), (n, 1), (max(n - 1, 0),)])),
                             elements=floats))
    acc = data.draw(hnp.arrays(np.float64, data.draw(st.sampled_from([(n, 3), (n, 2), (3, n)])), elements=floats))
    gyro = data.draw(hnp.arrays(np.float64, (n, 3), elements=st.floats(-1e6, 1e6)))
    try:
        rec = Recording(t, acc, gyro)
    except ValueError as exc:
        text = str(exc)
        assert "np." not in text and "dtype" not in text, text
        return
    assert len(rec) == n > 0
    assert np.all(np.isfinite(rec.acc)) and np.all(np.isfinite(rec.t)) and np.all(np.diff(rec.t) > 0)
