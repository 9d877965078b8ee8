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


# ------------------------------------------------------------- figures only where the curve shows them
def _rest(rng, rate, n, white, walk, columns=3):
    """White noise of density ``white`` [unit·√s] plus a rate random walk ``walk`` [unit/√s] per column."""
    return (rng.normal(0, white * np.sqrt(rate), (n, columns))
            + np.cumsum(rng.normal(0, walk / np.sqrt(rate), (n, columns)), axis=0))


@pytest.mark.parametrize("seed", [0, 1])
def test_white_noise_and_random_walk_recovered_within_20_percent(seed):
    """A long rest shows the −½ and the +½ slopes: both figures within 20 % of the simulated truth, on every axis;
    white noise meeting a random walk has a flat minimum but no floor of its own, so no bias instability."""
    rng = np.random.default_rng(seed)
    rate, n, white, walk = 100.0, 300_000, 2e-3, 3e-4  # 3000 s; the terms cross at τ = √3 N/K ≈ 12 s
    p = noise_parameters(_rest(rng, rate, n, white, walk), rate)
    np.testing.assert_allclose(p["white_noise_density"], white, rtol=0.05)
    np.testing.assert_allclose(p["random_walk"], walk, rtol=0.2)
    assert np.all(np.isnan(p["bias_instability"]))
    for key in ("white_noise_density", "random_walk"):  # a figure never exceeds its own bound
        assert np.all(p[key] <= p[key + "_bound"])
    assert np.all(p["random_walk_bound"] < 2 * walk)


def test_short_rest_gives_random_walk_only_as_a_bound():
    """50 s of rest cannot show a random walk whose slope appears only after minutes: NaN, and a bound
    that holds the truth."""
    rng = np.random.default_rng(2)
    rate, white, walk = 100.0, 2e-3, 3e-4
    p = noise_parameters(_rest(rng, rate, 5000, white, walk), rate)
    np.testing.assert_allclose(p["white_noise_density"], white, rtol=0.1)
    assert np.all(np.isnan(p["random_walk"]))
    assert np.all(p["random_walk_bound"] >= walk)


def test_bump_at_short_cluster_times_is_not_a_random_walk():
    """A vibration (a 16 Hz line) over white noise makes the curve rise at τ ≈ 0.03 s: read as a random walk it
    gives a figure far above what the longest clusters allow. The figure is NaN and the Kalibr file takes the
    bound, marked as such."""
    from imucalib.noise import BOUND_MARK, kalibr_yaml, noise_summary
    from imucalib.recording import Recording

    rng = np.random.default_rng(4)
    rate, n = 100.0, 5000
    t = np.arange(n) / rate
    line = 0.05 * np.sin(2 * np.pi * 16.0 * t)[:, None] * [1.0, 0.0, 0.0]
    acc = _rest(rng, rate, n, 3e-3, 1e-5) + line + [0.0, 0.0, 9.81]
    gyro = _rest(rng, rate, n, 2e-4, 1e-6)
    taus, adev = allan_deviation(acc[:, 0], rate)
    slope = np.diff(np.log(adev)) / np.diff(np.log(taus))
    assert np.any(slope[taus[:-1] < 0.1] > 0.3)  # the bump the old reading took for a random walk
    doc = noise_summary(Recording(t, acc, gyro, acc_unit="m/s^2", gyro_unit="rad/s"))
    a = doc["accelerometer"]
    assert np.isnan(a["random_walk"][0])
    text, notes = kalibr_yaml(a, doc["gyroscope"], rate)
    line_rw = next(x for x in text.splitlines() if x.startswith("accelerometer_random_walk:"))
    assert float(line_rw.split()[1]) == pytest.approx(max(a["random_walk_bound"]), rel=1e-6)
    assert BOUND_MARK in line_rw and any("upper bound" in x for x in notes)
    assert max(a["random_walk_bound"]) < 0.01


def test_bias_instability_floor_is_read_where_flat():
    """A bias that wanders as a sum of slow Gauss-Markov processes (a flicker-like floor, flat over two decades)
    under white noise: B is a figure, between 0.7× the curve's minimum over 0.664 and its own bound."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(5)
    rate, n = 100.0, 200_000
    x = rng.normal(0, 0.02, n)
    for tc in (2.0, 8.0, 32.0, 128.0):  # correlation times spread over the decades of the floor
        a = np.exp(-1 / (tc * rate))
        x = x + lfilter([1.0], [1.0, -a], rng.normal(0, 1e-3 * np.sqrt(1 - a**2), n))  # first-order Gauss-Markov
    taus, adev = allan_deviation(x, rate)
    p = noise_parameters(x, rate)
    assert np.isfinite(p["bias_instability"][0])
    assert 0.7 * adev.min() / 0.664 <= p["bias_instability"][0] <= p["bias_instability_bound"][0]
    assert np.isnan(p["random_walk"][0])


def test_confidence_matches_allantools_degrees_of_freedom():
    """δ = 1/√(2(K−1)) against allantools' equivalent degrees of freedom (Greenhall) of the overlapping Allan
    deviation, 1/√(2·edf): close for random-walk noise, on the safe (larger) side for white noise."""
    allantools = pytest.importorskip("allantools")
    from imucalib.noise import allan_confidence

    rate, n = 100.0, 5000
    for m in (1, 10, 100, 500):
        d = float(allan_confidence(np.array([m / rate]), rate, n)[0])
        white = 1 / np.sqrt(2 * allantools.edf_greenhall(alpha=0, d=2, m=m, N=n, overlapping=True))
        walk = 1 / np.sqrt(2 * allantools.edf_greenhall(alpha=-2, d=2, m=m, N=n, overlapping=True))
        assert 0.85 * d <= max(white, walk) <= 1.25 * d
        assert d >= 0.85 * white


def test_constant_column_is_below_the_resolution(tmp_path, capsys):
    from imucalib.cli import main
    from imucalib.io import write_csv
    from imucalib.noise import noise_summary
    from imucalib.recording import Recording

    rng = np.random.default_rng(6)
    n, rate = 6000, 100.0
    acc = np.round(rng.normal([0, 0, 1000], 2.0, (n, 3)))
    acc[:, 1] = 12.0  # a stuck (or very coarsely quantised) axis
    gyro = np.round(rng.normal(0, 3.0, (n, 3)))
    rec = Recording(np.arange(n) / rate, acc, gyro)
    doc = noise_summary(rec)["accelerometer"]
    assert doc["constant"] == [False, True, False]
    assert np.isnan(doc["white_noise_density"][1]) and np.isnan(doc["white_noise_density_bound"][1])
    assert doc["resolution"][0] == 1.0
    assert any("y is constant" in x and "below the resolution" in x for x in doc["notes"])
    write_csv(tmp_path / "stuck.csv", rec)
    assert main(["noise", str(tmp_path / "stuck.csv"), "--whole"]) == 0
    out, err = capsys.readouterr()
    assert "const" in out and "e-3" not in out.split("accelerometer")[1].split("gyroscope")[0].split(",")[1]
    assert "below the resolution" in err


def test_noise_refuses_a_time_base_and_names_the_mix_up(tmp_path, capsys):
    """Arduino millis() stamps (16 ms steps) read as microseconds (--time-unit us): 62.5 kHz, refused, naming the
    mix-up; without --time-unit they are read as ms (the one unit giving an IMU's rate, with a note), and the
    densities come out √1000 larger than in µs, as they should."""
    from imucalib.cli import main

    rng = np.random.default_rng(8)
    n = 4000
    stamps = np.arange(n) * 16  # millis() at 62.5 Hz
    acc = rng.normal([0, 0, 9.81], 0.02, (n, 3))
    gyro = rng.normal(0, 0.002, (n, 3))
    body = "\n".join(",".join(f"{v:.6g}" for v in (t, *a, *g)) for t, a, g in zip(stamps, acc, gyro, strict=True))
    (tmp_path / "arduino.csv").write_text("t,ax,ay,az,gx,gy,gz\n" + body + "\n")
    args = ["noise", str(tmp_path / "arduino.csv"), "--whole", "--acc-unit", "m/s^2", "--gyro-unit", "rad/s"]
    assert main([*args, "--time-unit", "us"]) == 2
    err = capsys.readouterr().err
    assert "milliseconds read as microseconds" in err and "--time-unit ms" in err and "Traceback" not in err
    assert main([*args, "--json"]) == 0
    assert "was read in milliseconds" in capsys.readouterr().err
    assert main([*args, "--time-unit", "ms", "--json"]) == 0
    doc = __import__("json").loads(capsys.readouterr().out)
    assert doc["rate_hz"] == pytest.approx(62.5)
    np.testing.assert_allclose(doc["accelerometer"]["white_noise_density"], 0.02 / np.sqrt(62.5), rtol=0.1)


def test_noise_checks_the_rest_against_the_declared_unit(tmp_path, capsys):
    """m/s² data declared g: |a| is 9.8 g at rest; refused, naming the unit the data look like."""
    from imucalib.cli import main
    from imucalib.io import write_csv
    from imucalib.noise import check_rest
    from imucalib.recording import Recording

    rng = np.random.default_rng(9)
    n, rate = 3000, 100.0
    acc = rng.normal([0, 0, 9.81], 0.02, (n, 3))
    rec = Recording(np.arange(n) / rate, acc, rng.normal(0, 0.002, (n, 3)), acc_unit="g", gyro_unit="rad/s")
    with pytest.raises(ValueError, match="look like m/s\\^2.*--acc-unit"):
        check_rest(rec)
    si = Recording(rec.t, acc, rec.gyro, acc_unit="m/s^2", gyro_unit="rad/s")
    assert check_rest(si) == []
    slightly = Recording(rec.t, acc * 1.08, rec.gyro, acc_unit="m/s^2", gyro_unit="rad/s")
    assert any("8 % from gravity" in w for w in check_rest(slightly))
    write_csv(tmp_path / "rest.csv", rec)  # the header says g
    assert main(["noise", str(tmp_path / "rest.csv"), "--whole"]) == 2
    assert "look like m/s^2" in capsys.readouterr().err


def test_degrees_of_freedom_match_allantools_greenhall():
    """NIST SP 1065's approximations of the overlapping Allan variance's degrees of freedom against Greenhall's
    algorithm (allantools.edf_greenhall) for white, flicker and random-walk frequency noise, over the cluster
    times a term is read at."""
    allantools = pytest.importorskip("allantools")
    from imucalib.noise import allan_dof

    rate = 100.0
    for n in (5000, 300_000):
        for m in (10, 100, n // 50, n // 10):
            for term, alpha in (("white_noise_density", 0), ("bias_instability", -1), ("random_walk", -2)):
                ours = float(allan_dof(np.array([m / rate]), rate, n, term)[0])
                ref = allantools.edf_greenhall(alpha=alpha, d=2, m=m, N=n + 1, overlapping=True)
                assert ours == pytest.approx(ref, rel=0.1), (n, m, term)
    with pytest.raises(ValueError, match="unknown noise term"):
        allan_dof(np.array([1.0]), rate, 5000, "flicker")


def test_chi2_limits_match_allantools_confidence_interval():
    """The χ² limits of a deviation against allantools.confidence_interval at the same two-sided confidence,
    and the few-cluster asymmetry: the upper limit well above 1 + 2δ."""
    allantools = pytest.importorskip("allantools")
    from scipy.special import erf

    from imucalib.noise import chi2_limits

    for dof in (5.0, 12.0, 50.0, 4000.0):
        lower, upper = chi2_limits(np.array([dof]), confidence=2.0)
        lo, hi = allantools.confidence_interval(1.0, dof, ci=erf(2 / np.sqrt(2)))
        assert lower[0] == pytest.approx(lo, rel=1e-9) and upper[0] == pytest.approx(hi, rel=1e-9)
    lower, upper = chi2_limits(np.array([8.0]))
    assert upper[0] > 1 + 2 / np.sqrt(2 * 8.0) + 0.3 and lower[0] > 1 - 2 / np.sqrt(2 * 8.0)


@pytest.mark.slow
def test_random_walk_read_only_where_the_clusters_read_it_within_a_fifth():
    """3000 s rests of both sensors (white noise crossing the random walk at 12 and 17 s): where the +½ slope
    shows only at the longest cluster times (ten to forty clusters) a reading 30 % low is no rarity, so it is
    a bound; every figure given is within 20 % of the truth, with no bias over the axes (the old weighting,
    which favoured the region's short end where the white noise holds most of σ², read the gyroscope's 4 %
    low), and the bound holds the truth."""
    rate, n = 100.0, 300_000
    sensors = {"accelerometer": (2e-3, 3e-4), "gyroscope": (2e-4, 2e-5)}  # (N, K) as benchmarks/bench_noise.py
    ratios = {name: [] for name in sensors}
    for seed in range(12):
        rng = np.random.default_rng(seed)
        for name, (white, walk) in sensors.items():
            p = noise_parameters(_rest(rng, rate, n, white, walk), rate)
            if seed == 1 and name == "gyroscope":
                # the +½ slope shows from τ = 80 s on only (37 clusters): the reading there was 0.70× the truth
                assert np.isnan(p["random_walk"][0]) and p["random_walk_bound"][0] > 0.95 * walk
            ratios[name] += list(p["random_walk"] / walk)
            np.testing.assert_allclose(p["white_noise_density"], white, rtol=0.01)
    for name, r in ratios.items():
        r = np.array(r)
        figures = r[np.isfinite(r)]
        assert figures.size >= (30 if name == "accelerometer" else 20), name
        assert np.all(np.abs(figures - 1) <= 0.2), (name, figures)
        assert abs(np.median(figures) - 1) < 0.03, name
