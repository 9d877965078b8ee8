"""The HTML report and the fit figure: units, σ larger than the value, pose coverage, reference lines."""

import re
import warnings

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from imucalib.recording import Interval  # noqa: E402
from imucalib.report import fit_figure, html_report, parameter_unit, reference_levels  # noqa: E402
from imucalib.verdict import THRESHOLDS  # noqa: E402


@pytest.fixture(scope="module")
def fitted():
    from imucalib.methods import calibrate
    from imucalib.scenarios import session

    sim = session("zhang2021", rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cal = calibrate(sim.recording, method="tedaldi2014", gravity=sim.truth.gravity)
    return cal, sim.recording, [Interval(a, b) for a, b in cal.fit["intervals"]]


def test_parameter_units():
    from imucalib.scenarios import table1_truth

    cal = table1_truth()  # accelerometer in g, gyroscope in counts
    assert parameter_unit("accelerometer.scale.x", cal) == "m/s² per g"
    assert parameter_unit("accelerometer.scale_cubic.z", cal) == "m/s² per g³"
    assert parameter_unit("accelerometer.bias.y", cal) == "g"
    assert parameter_unit("gyroscope.scale.x", cal) == "rad/s per counts"
    assert parameter_unit("gyroscope.g_sensitivity.xz", cal) == "counts per m/s²"
    assert parameter_unit("gyroscope.misalignment.zx", cal) == "1"
    assert parameter_unit("lever_arm.x", cal) == "m"


def test_html_has_units_marks_large_sigmas_and_shows_pose_coverage(fitted, tmp_path):
    cal, rec, ivs = fitted
    unc = dict(cal.fit["uncertainty"])
    params = cal.parameters()
    # two terms made undetermined: a 1σ larger than the value
    for name in ("gyroscope.misalignment.xy", "accelerometer.bias.z"):
        unc[name] = 3 * abs(params[name])
    cal = cal.with_(fit={**cal.fit, "uncertainty": unc})
    page = html_report(cal, tmp_path / "r.html", recording=rec, intervals=ivs).read_text(encoding="utf-8")
    large = {n for n, s in unc.items() if s is not None and np.isfinite(s) and s > abs(params.get(n, np.inf))}
    assert {"gyroscope.misalignment.xy", "accelerometer.bias.z"} <= large
    marked = set(re.findall(r"<tr class='sigma-large'><td>([^<]+)</td>", page))
    assert marked == large
    assert page.count("<span class='sigma-large-mark'>σ &gt; |value|</span>") == len(large) + 1  # + the legend
    # the unit column
    raw = cal.units["gyroscope"]["raw"]
    assert re.search(r"<td>gyroscope\.scale\.x</td><td>[^<]+</td><td>rad/s per " + re.escape(raw) + "</td>", page)
    assert re.search(r"<td>accelerometer\.bias\.x</td><td>[^<]+</td><td>"
                     + re.escape(cal.units["accelerometer"]["raw"].replace("m/s^2", "m/s²")) + "</td>", page)
    # the pose coverage, every axis with its range
    assert "Pose coverage" in page
    for axis, (lo, hi) in cal.fit["pose_coverage"].items():
        assert f"<tr><td>{axis}</td><td>{lo:+.2f}</td><td>{hi:+.2f}</td>" in page
    # the figure's reference lines, named with their values
    ref = reference_levels(cal)
    assert f"± the white-noise floor {cal.fit['accelerometer_noise_floor']:.3g} m/s²" in page
    assert f"{THRESHOLDS['gyro_error_floor_deg'][0]:g}° acceptable" in page
    assert f"{THRESHOLDS['gyro_error_floor_deg'][1]:g}° rejected" in page
    assert ref["angle_acceptable_deg"] == THRESHOLDS["gyro_error_floor_deg"][0]


def _hlines(ax):
    """y of every horizontal line drawn across an axes."""
    out = []
    for line in ax.get_lines():
        y = np.asarray(line.get_ydata(), dtype=float)
        if y.size == 2 and y[0] == y[1]:
            out.append(float(y[0]))
    return out


def test_fit_figure_reference_lines_make_a_failure_look_like_one(fitted):
    import matplotlib.pyplot as plt

    cal, rec, ivs = fitted
    ok, bad = THRESHOLDS["gyro_error_floor_deg"]
    fig = fit_figure(cal, rec, ivs)
    floor_mm = cal.fit["accelerometer_noise_floor"] * 1e3
    np.testing.assert_allclose(sorted(y for y in _hlines(fig.axes[1])), [-floor_mm, floor_mm])
    lines = _hlines(fig.axes[2])
    assert ok in lines and bad in lines
    assert cal.fit["gyroscope_angle_error_predicted_deg"] in lines
    good_top = fig.axes[2].get_ylim()[1]
    assert good_top >= bad  # the rejecting angle is always in view: small errors look small
    heights = [p.get_height() for p in fig.axes[2].patches]
    assert np.mean(heights) == pytest.approx(cal.fit["gyroscope_angle_error_mean_deg"], rel=1e-9)
    assert max(heights) < bad  # this good calibration's bars stay well below the rejecting angle
    plt.close(fig)
    # the same data with the gyroscope's y and z scales of the wrong sign: errors of tens of degrees or more
    g = cal.gyroscope
    broken = cal.with_(gyroscope=g.with_(scale=g.scale * np.array([1, -1, -1])))
    fig = fit_figure(broken, rec, ivs)
    heights = np.array([p.get_height() for p in fig.axes[2].patches])
    colours = [p.get_facecolor() for p in fig.axes[2].patches]
    assert heights.max() > 20 and fig.axes[2].get_ylim()[1] >= heights.max()
    red = plt.matplotlib.colors.to_rgba("tab:red")
    assert sum(np.allclose(c, red) for c in colours) == int(np.sum(heights > bad))
    plt.close(fig)
