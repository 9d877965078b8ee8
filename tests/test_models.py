"""The canonical model: forward∘inverse, invertibility, named parameters, JSON."""

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.models import NotInvertibleError, TriadModel

G = 9.80665


def _model(shape, order, with_g, rng):
    t = np.eye(3)
    from imucalib.models import MISALIGNMENT_SHAPES

    for i, j in MISALIGNMENT_SHAPES[shape]:
        t[i, j] = rng.uniform(-0.05, 0.05)
    k2 = rng.uniform(-1e-3, 1e-3, 3) if order >= 2 else np.zeros(3)
    k3 = rng.uniform(1e-6, 1e-5, 3) if order >= 3 else np.zeros(3)
    return TriadModel(misalignment=t, scale=rng.uniform(0.9, 1.1, 3) * 0.01, scale_quadratic=k2 * 1e-4,
                      scale_cubic=k3 * 1e-8, bias=rng.uniform(-50, 50, 3),
                      g_sensitivity=rng.uniform(-1e-3, 1e-3, (3, 3)) if with_g else np.zeros((3, 3)),
                      shape=shape)


@pytest.mark.parametrize("shape", ["upper", "full", "lower"])
@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("with_g", [False, True])
def test_forward_inverse_identity_over_full_range(shape, order, with_g):
    rng = np.random.default_rng(hash((shape, order, with_g)) % 2**32)
    m = _model(shape, order, with_g, rng)
    # ±16 g (accelerometer-like) in SI over a dense grid of directions and magnitudes
    si = rng.uniform(-16 * G, 16 * G, size=(2000, 3))
    force = rng.uniform(-16 * G, 16 * G, size=(2000, 3))
    raw = m.inverse(si, force)
    back = m.forward(raw, force)
    np.testing.assert_allclose(back, si, rtol=1e-12, atol=1e-12 * 16 * G)


@pytest.mark.parametrize("rows", [1, 255, 256, 5000])  # both sides of the axis-to-a-row layout
@pytest.mark.parametrize("order", [1, 3])
@pytest.mark.parametrize("with_g", [False, True])
def test_forward_is_the_formula_bit_for_bit(rows, order, with_g):
    rng = np.random.default_rng(rows * 10 + order + 2 * with_g)
    m = _model("full", order, with_g, rng).with_(output_bias=rng.uniform(-0.1, 0.1, 3) if order == 3 else np.zeros(3))
    raw = np.round(rng.normal(0, 3000, size=(rows, 3)))  # counts: some readings equal, spanning every sign
    force = rng.uniform(-16 * G, 16 * G, size=(rows, 3))
    x = raw - m.bias - (force @ m.g_sensitivity.T if with_g else 0.0)
    want = (x * (m.scale + x * (m.scale_quadratic + x * m.scale_cubic)) + m.output_bias) @ m.misalignment.T
    got = m.forward(np.asfortranarray(raw), force)  # readings in another layout as well
    assert np.array_equal(got.view(np.int64), want.view(np.int64))  # every bit, the zeros' signs too
    assert got.flags.c_contiguous and got.shape == (rows, 3)


def test_not_invertible_is_a_documented_error():
    m = TriadModel(scale=[1.0, 1.0, 1.0], scale_quadratic=[0.5, 0, 0], shape="upper")
    # f(x) = x + 0.5x² is monotonic only for x > −1, where f > −0.5
    ok = m.inverse(np.array([[-0.4, 0.0, 0.0], [3.0, 1.0, -2.0]]))
    np.testing.assert_allclose(m.forward(ok), [[-0.4, 0.0, 0.0], [3.0, 1.0, -2.0]], rtol=1e-12)
    with pytest.raises(NotInvertibleError, match="x-axis scale polynomial .* is not monotonic"):
        m.inverse(np.array([[-0.6, 0.0, 0.0]]))


def test_named_parameters_round_trip():
    rng = np.random.default_rng(1)
    cal = Calibration(accelerometer=_model("upper", 3, False, rng),
                      gyroscope=_model("full", 3, True, rng), lever_arm=[0.01, 0.02, 0.03])
    p = cal.parameters()
    assert "accelerometer.scale_quadratic.y" in p and "gyroscope.misalignment.xz" in p
    assert "gyroscope.g_sensitivity.yx" in p and "lever_arm.x" in p
    assert "accelerometer.misalignment.yx" not in p  # not free in an upper-triangular T
    zero = Calibration(accelerometer=TriadModel(shape="upper"), gyroscope=TriadModel(shape="full"))
    assert zero.with_parameters(p).parameters() == p
    with pytest.raises(ValueError, match="not free in a misalignment of shape 'upper'"):
        zero.with_parameters({"accelerometer.misalignment.zx": 0.1})
    with pytest.raises(ValueError, match="unknown parameter 'thermometer.bias.x'"):
        zero.with_parameters({"thermometer.bias.x": 1.0})


def test_json_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    cal = Calibration(accelerometer=_model("upper", 3, False, rng),
                      gyroscope=_model("full", 2, True, rng), lever_arm=[0.01, 0.02, 0.03],
                      method="zhang2021", model="all", fit={"static_intervals": 40})
    cal.save(tmp_path / "c.json")
    back = Calibration.load(tmp_path / "c.json")
    assert back.parameters() == cal.parameters()
    assert back.fit == {"static_intervals": 40}
    (tmp_path / "v3.json").write_text('{"format": "imucalib.calibration", "format_version": 3}')
    with pytest.raises(ValueError, match="format_version 3 is not supported"):
        Calibration.load(tmp_path / "v3.json")


def test_invalid_models_are_refused():
    with pytest.raises(ValueError, match="unit diagonal"):
        TriadModel(misalignment=2 * np.eye(3))
    with pytest.raises(ValueError, match="may only have entries xy, xz, yz"):
        TriadModel(misalignment=[[1, 0, 0], [0.1, 1, 0], [0, 0, 1]], shape="upper")
    with pytest.raises(ValueError, match="scale .k1. must be non-zero"):
        TriadModel(scale=[1, 0, 1])
    with pytest.raises(ValueError, match="misalignment shape must be one of"):
        TriadModel(shape="diagonal")
