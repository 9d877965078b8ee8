"""One value, one place: physical constants and detector presets, and the command line and the verdict
checking a declared gravity against the same range."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import pytest

from imucalib import constants, presets
from imucalib.calibration import Calibration
from imucalib.cli._common import gravity_value
from imucalib.verdict import assess

SRC = Path(__file__).resolve().parent.parent / "src" / "imucalib"


def _numbers(path: Path) -> list[tuple[int, float]]:
    """Every numeric literal of a module, with its line (docstrings and comments are not literals)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    return [(node.lineno, node.value) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and type(node.value) in (int, float)]


def test_standard_gravity_and_the_gravity_range_are_written_once():
    assert constants.STANDARD_GRAVITY == 9.80665 and constants.G0 is constants.STANDARD_GRAVITY
    lo, hi = constants.GRAVITY_RANGE
    # WGS 84 normal gravity at the equator and the poles (NIMA TR8350.2, eq. 4-1) lie inside, the
    # equator's less the free-air loss of the highest summit (8.85 km × 3.086e-6 s⁻²) too
    assert lo < 9.7803253359 - 8850 * 3.086e-6 and 9.8321849378 < hi
    found = [f"{path.relative_to(SRC)}:{line} {value}" for path in sorted(SRC.rglob("*.py"))
             if path.name != "constants.py"
             for line, value in _numbers(path) if value in (9.80665, lo, hi, 9.7, 9.9)]
    assert found == [], "gravity written outside constants.py: " + ", ".join(found)


@pytest.mark.parametrize("g", [9.6, 9.72, constants.GRAVITY_RANGE[0] - 1e-3, constants.GRAVITY_RANGE[0],
                               9.80665, constants.GRAVITY_RANGE[1], constants.GRAVITY_RANGE[1] + 1e-3, 9.9, 1.0])
def test_the_command_line_and_the_verdict_take_the_same_gravity_range(g, capsys):
    assert gravity_value(repr(g)) == g
    warned = "--gravity" in capsys.readouterr().err
    rejected = any("declared gravity" in r for r in assess(Calibration(gravity=g))["verdict_reasons"])
    assert warned == rejected == (not constants.GRAVITY_RANGE[0] <= g <= constants.GRAVITY_RANGE[1])


def _default(fn, name):
    return inspect.signature(fn).parameters[name].default


def test_detectors_and_their_callers_default_to_the_presets():
    from imucalib import segment, validation
    from imucalib.methods import tedaldi2014

    for fn in (segment.detect_intervals, tedaldi2014.calibrate):
        assert tuple(_default(fn, "multipliers")) == presets.MULTIPLIERS == tuple(range(2, 11))
        # the window and shortest run follow from the minimum hold (presets.hold_settings) unless given
        assert _default(fn, "min_hold") == presets.MIN_HOLD
        assert _default(fn, "window") is None and _default(fn, "min_interval") is None
    assert _default(segment.static_at, "window") == presets.VARIANCE_WINDOW
    assert (_default(segment.detect_static_gyro, "window"), _default(segment.detect_static_gyro, "multiplier")) \
        == (presets.GYRO_VARIANCE_WINDOW, presets.GYRO_MULTIPLIER) == (2.0, 6.0)  # Zhang 2021 §IV-A, RD1
    assert _default(segment.find_initial_rest, "factor") == presets.REST_FACTOR
    assert _default(segment.gyro_still, "rate_limit") == presets.STILL_RATE
    assert segment.MIN_INTERVALS is presets.MIN_INTERVALS
    assert validation.THRESHOLD_MULTIPLIER == presets.VALIDATE_MULTIPLIER


def test_the_detect_fall_command_defaults_to_the_preset(capsys):
    from imucalib.cli import main

    with pytest.raises(SystemExit):
        main(["detect-fall", "--help"])
    assert f"(default {presets.FALL_THRESHOLD})" in capsys.readouterr().out
