"""The fit figure shows panels only for what was recorded, and does not draw lines across time gaps."""

import warnings

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from imucalib.recording import Interval, Recording  # noqa: E402
from imucalib.report import _broken_at_gaps, fit_figure  # noqa: E402


@pytest.fixture(scope="module")
def handheld():
    from imucalib.scenarios import session

    return session("handheld", rng=2)


def _fit(rec, method):
    from imucalib.methods import calibrate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate(rec, method=method)
    return cal, [Interval(a, b) for a, b in cal.fit["intervals"]]


def test_an_accelerometer_only_session_has_no_gyroscope_panel(handheld):
    import matplotlib.pyplot as plt

    rec = handheld.recording
    acc_only = Recording(rec.t, rec.acc, None, acc_unit=rec.acc_unit)
    cal, ivs = _fit(acc_only, "ellipsoid")
    assert cal.gyroscope is None
    fig = fit_figure(cal, acc_only, ivs)
    assert len(fig.axes) == 2 and all("gyroscope" not in ax.get_title() for ax in fig.axes)
    plt.close(fig)
    cal, ivs = _fit(rec, "tedaldi2014")
    fig = fit_figure(cal, rec, ivs)
    assert len(fig.axes) == 3 and "gyroscope" in fig.axes[2].get_title()
    plt.close(fig)


def test_lines_stop_at_the_gaps_between_blocks():
    t = np.r_[np.arange(5) * 0.01, 0.0 + np.arange(4) * 0.01, 10 + np.arange(3) * 0.01]  # back to 0, then +10 s
    y = np.arange(t.size, dtype=float)
    tt, yy = _broken_at_gaps(t, y)
    assert np.flatnonzero(np.isnan(tt)).tolist() == [5, 10] and np.isnan(yy[[5, 10]]).all()
    assert np.array_equal(tt[~np.isnan(tt)], t) and np.array_equal(yy[~np.isnan(yy)], y)
    even = np.arange(10) * 0.01
    assert np.array_equal(_broken_at_gaps(even, even)[0], even)  # an unbroken recording is drawn as it is
