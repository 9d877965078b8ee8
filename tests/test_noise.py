"""Allan deviation against the closed forms of white noise and random walk."""

import numpy as np
import pytest

from imucalib.noise import allan_deviation, noise_parameters


def test_white_noise_follows_minus_half_slope():
    rng = np.random.default_rng(0)
    rate, sigma = 100.0, 0.02
    x = rng.normal(0, sigma, size=(200_000, 2))
    taus, adev = allan_deviation(x, rate)
    expected = sigma / np.sqrt(taus * rate)  # σ(τ) = σ/√(τ f_s)
    ok = taus <= 10
    np.testing.assert_allclose(adev[ok, 0], expected[ok], rtol=0.1)
    p = noise_parameters(x, rate)
    np.testing.assert_allclose(p["white_noise_per_sample"], sigma, rtol=0.05)


def test_random_walk_follows_plus_half_slope():
    rng = np.random.default_rng(1)
    rate, k = 100.0, 1e-3  # rate random walk density [unit/√s]
    x = np.cumsum(rng.normal(0, k / np.sqrt(rate), size=400_000))
    taus, adev = allan_deviation(x, rate, taus=np.array([50.0, 100.0, 200.0]))
    np.testing.assert_allclose(adev, k * np.sqrt(taus / 3), rtol=0.35)  # few long clusters: loose


def test_errors():
    with pytest.raises(ValueError, match="at least 8 samples"):
        allan_deviation(np.ones(5), 100.0)
    with pytest.raises(ValueError, match="no cluster time fits"):
        allan_deviation(np.ones(100), 100.0, taus=[10.0])


def test_kalibr_file_from_a_long_rest(tmp_path, capsys):
    from imucalib.cli import main
    from imucalib.io import write_csv
    from imucalib.recording import Recording

    rng = np.random.default_rng(3)
    rate, n = 100.0, 400_000  # 4000 s at rest
    na, ng = 2e-3, 2e-4  # white noise densities [unit·√s]
    ka, kg = 3e-4, 2e-5  # rate random walks [unit/√s]
    walk = lambda k: np.cumsum(rng.normal(0, k / np.sqrt(rate), (n, 3)), axis=0)  # noqa: E731
    acc = np.array([0.0, 0.0, 9.81]) + rng.normal(0, na * np.sqrt(rate), (n, 3)) + walk(ka)
    gyro = rng.normal(0, ng * np.sqrt(rate), (n, 3)) + walk(kg)
    write_csv(tmp_path / "rest.csv", Recording(np.arange(n) / rate, acc, gyro, acc_unit="m/s^2", gyro_unit="rad/s"))
    assert main(["noise", str(tmp_path / "rest.csv"), "--whole", "--kalibr", str(tmp_path / "imu.yaml"),
                 "--json"]) == 0
    doc = __import__("json").loads(capsys.readouterr().out)
    values = {}
    for line in (tmp_path / "imu.yaml").read_text().splitlines():
        if ":" in line and not line.startswith("#"):
            key, rest = line.split(":", 1)
            values[key] = rest.split("#")[0].strip()
    assert float(values["accelerometer_noise_density"]) == pytest.approx(na, rel=0.15)
    assert float(values["gyroscope_noise_density"]) == pytest.approx(ng, rel=0.15)
    # the file holds the largest axis; each axis's random walk is near the truth (long clusters are few: ±30 %)
    for name, k in (("accelerometer", ka), ("gyroscope", kg)):
        per_axis = np.array(doc[name]["random_walk"])
        assert float(values[f"{name}_random_walk"]) == pytest.approx(per_axis.max(), rel=1e-6)
        assert np.median(per_axis) == pytest.approx(k, rel=0.35)
    assert float(values["update_rate"]) == pytest.approx(rate)
    capsys.readouterr()
    raw = Recording(np.arange(1000) / rate, acc[:1000], gyro[:1000])  # counts
    write_csv(tmp_path / "raw.csv", raw)
    assert main(["noise", str(tmp_path / "raw.csv"), "--whole", "--kalibr", str(tmp_path / "x.yaml")]) == 2
    assert "needs SI units" in capsys.readouterr().err


def test_overlapping_allan_deviation_matches_allantools():
    """Our overlapping Allan deviation against allantools.oadev (NIST SP 1065 eq. 11) on white noise plus a
    rate random walk: the same estimator, so equal to rounding."""
    allantools = pytest.importorskip("allantools")
    rng = np.random.default_rng(7)
    rate, n = 200.0, 60_000
    x = rng.normal(0, 0.05, (n, 3)) + np.cumsum(rng.normal(0, 2e-4, (n, 3)), axis=0) + [1.0, -2.0, 9.81]
    taus, adev = allan_deviation(x, rate)
    assert taus.size > 30
    for j in range(3):
        t2, ref, _, _ = allantools.oadev(x[:, j], rate=rate, data_type="freq", taus=taus)
        np.testing.assert_allclose(t2, taus, rtol=1e-12)
        np.testing.assert_allclose(adev[:, j], ref, rtol=1e-10)
    # explicit cluster times, one column
    t1, a1 = allan_deviation(x[:, 1], rate, taus=[0.05, 1.0, 10.0])
    _, ref1, _, _ = allantools.oadev(x[:, 1], rate=rate, data_type="freq", taus=t1)
    np.testing.assert_allclose(a1, ref1, rtol=1e-10)
