"""A calibration file's text cannot carry code into an export or markup into a report.

Calibration files come from colleagues, stores and downloads. Two defences,
each tested on its own: loading refuses text entries outside a short
charset (:func:`imucalib.calibration.check_document`), and every export
escapes what it writes (:mod:`imucalib.export.text`), so a calibration made in
Python with any text at all still gives a C header whose code is exactly that
of a plain one (gcc's view, comments stripped) and YAML that parses to exactly
the expected keys and values.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from imucalib.calibration import Calibration, CalibrationFileError  # noqa: E402
from imucalib.cli import main  # noqa: E402
from imucalib.export import to_c, to_kalibr, to_openvins  # noqa: E402
from imucalib.export.text import c_comment, comment_text, yaml_scalar  # noqa: E402
from synth import linear_truth  # noqa: E402

GCC = shutil.which("gcc")
SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
#: any text, with the sequences that end comments and lines made likely
HOSTILE = st.lists(st.one_of(st.sampled_from(["*/", "/*", "*", "/", "\\", "\n", "\r", "\u2028", "\u0085", "??/",
                                              "#", ":", "\"", "'", "<script>", "&", "{", "-", "#define X 1", "imu0:",
                                              "\t", "\x00"]),
                             st.characters()), max_size=20).map("".join)
#: the text entries of a calibration
FIELDS = ("method", "model", "created", "device")


def _calibration(**text) -> Calibration:
    return linear_truth().with_(**{"method": "plain", "model": "linear", "created": "2026-01-01T00:00:00Z", **text})


def _gcc(source: str, tmp_path, *args: str) -> subprocess.CompletedProcess:
    path = tmp_path / "calibration.h"
    path.write_text(source, encoding="utf-8")
    return subprocess.run([GCC, "-std=c99", "-x", "c", *args, str(path)], capture_output=True, text=True,
                          timeout=60)


def _code(source: str, tmp_path) -> str:
    """The header's code with its comments removed, as gcc's preprocessor sees it (no macro expanded)."""
    run = _gcc(source, tmp_path, "-fpreprocessed", "-dD", "-E", "-P")
    assert run.returncode == 0, run.stderr
    return run.stdout


@pytest.mark.skipif(GCC is None, reason="gcc is not installed: the C header cannot be compiled")
@SETTINGS
@given(st.dictionaries(st.sampled_from([*FIELDS, "acc_raw", "gyro_raw"]), HOSTILE, min_size=1))
def test_any_text_in_a_calibration_leaves_the_c_header_s_code_unchanged(tmp_path, text):
    units = {"accelerometer": {"raw": text.pop("acc_raw", "counts"), "calibrated": "m/s^2"},
             "gyroscope": {"raw": text.pop("gyro_raw", "counts"), "calibrated": "rad/s"}}
    hostile = to_c(_calibration(units=units, **text))
    plain = to_c(_calibration())
    compiled = _gcc(hostile + "\nint main(void) { double a[3], g[3]; imucalib_apply(a, g, a, g); return 0; }\n",
                    tmp_path, "-fsyntax-only", "-Wall", "-Werror", "-Wcomment")
    assert compiled.returncode == 0, compiled.stderr
    assert _code(hostile, tmp_path) == _code(plain, tmp_path)  # the same declarations and macros, nothing more


def _yaml(text: str) -> dict:
    yaml = pytest.importorskip("yaml")
    lines = text.splitlines()
    if lines and lines[0].startswith("%YAML:"):  # OpenCV's header, which PyYAML does not take
        lines = lines[1:]
    return yaml.safe_load("\n".join(lines))


@SETTINGS
@given(st.dictionaries(st.sampled_from(FIELDS), HOSTILE, min_size=1), st.sampled_from(["openvins", "kalibr"]))
def test_any_text_in_a_calibration_leaves_the_yaml_exports_keys_and_values_unchanged(text, fmt):
    def export(cal):
        if fmt == "openvins":
            return to_openvins(cal, raw_scale=(1.0, 1.0), rostopic="/imu0")[0]
        return to_kalibr(cal, raw_scale=(1.0, 1.0), rostopic="/imu0")[0]

    hostile, plain = export(_calibration(**text)), export(_calibration())
    assert _yaml(hostile) == _yaml(plain)
    assert set(_yaml(hostile)) == {"imu0"}
    # only the comment line changes, and it stays one line
    assert len(hostile.splitlines()) == len(plain.splitlines())


@given(st.one_of(HOSTILE, st.sampled_from(["~", "Off", "NULL", "y", "/imu0", "1.5", "-", "[a]", "", " x"])))
def test_the_escapes_keep_text_on_one_printable_ascii_line(text):
    for out in (comment_text(text), c_comment(text)):
        assert all(" " <= c <= "~" for c in out) and "\\" not in out
    assert "*/" not in c_comment(text) and "/*" not in c_comment(text) and "??" not in c_comment(text)
    yaml = pytest.importorskip("yaml")
    assert yaml.safe_load(f"rostopic: {yaml_scalar(text)}") == {"rostopic": text}


@pytest.mark.parametrize("topic", ["imu0\nimu1: {}", "/imu0 # x", "a: b", "\"/imu0\""])
def test_a_topic_that_is_not_a_ros_name_is_refused(topic):
    from imucalib.export import ExportError

    with pytest.raises(ExportError, match="not a ROS name"):
        to_kalibr(_calibration(), raw_scale=(1.0, 1.0), rostopic=topic)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from([*FIELDS, "units.accelerometer.calibrated", "thermal.source", "fit.verdict_reasons"]),
       HOSTILE)
def test_loading_refuses_text_outside_the_charset_or_keeps_it_exactly(tmp_path, key, text):
    doc = _calibration().to_dict()
    if key == "thermal.source":
        doc["thermal"] = {"reference_c": 25.0, "range_c": [20.0, 30.0], "parameters": {}, "source": text}
    elif key == "fit.verdict_reasons":
        doc["fit"] = {"verdict": "suspect", "verdict_reasons": [text]}
    elif key.startswith("units."):
        doc["units"]["accelerometer"]["calibrated"] = text
    else:
        doc[key] = text
    path = tmp_path / "c.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    try:
        cal = Calibration.load(path)
    except CalibrationFileError as exc:
        assert str(path) in str(exc) and key.split(".")[0] in str(exc)
        return
    if key in ("device", "fit.verdict_reasons"):  # free text: one printable line
        assert text.isprintable() and len(text) <= 2000
    else:  # identifiers and units: nothing that can leave a comment, a scalar or an HTML element
        assert text and not set(text) - set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_.:+->^/")
        assert "*" not in text and "#" not in text and "<" not in text
    value = {"units.accelerometer.calibrated": lambda: cal.units["accelerometer"]["calibrated"],
             "thermal.source": lambda: cal.thermal.source,
             "fit.verdict_reasons": lambda: cal.fit["verdict_reasons"][0]}.get(key, lambda: getattr(cal, key))()
    assert value == text


def test_export_refuses_a_calibration_file_carrying_code(tmp_path, capsys):
    doc = _calibration().to_dict()
    doc["method"] = "x */ __attribute__((constructor)) static void run(void) { system(\"id\"); } /*"
    (tmp_path / "c.json").write_text(json.dumps(doc), encoding="utf-8")
    doc["method"] = "x\nimu0:\n  accelerometer_noise_density: 1.0e+09"
    (tmp_path / "y.json").write_text(json.dumps(doc), encoding="utf-8")
    assert main(["export", str(tmp_path / "c.json"), "-o", str(tmp_path / "c.h")]) == 2
    assert main(["export", str(tmp_path / "y.json"), "--format", "kalibr", "--raw-scale", "1,1"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and not (tmp_path / "c.h").exists()
    assert err.count("'method'") == 2 and "is not a name imucalib writes" in err and "Traceback" not in err


def test_the_html_report_escapes_every_text(tmp_path):
    from imucalib.report import html_report

    cal = _calibration(method="<script>alert(1)</script>", model="a&b", device="<img src=x onerror=alert(1)>",
                       fit={"verdict": "suspect", "verdict_reasons": ["<b>bold</b>"], "verdict_notes": ["</li><i>"],
                            "quality_flags": ["<iframe>"]})
    page = html_report(cal, tmp_path / "r.html").read_text(encoding="utf-8")
    for raw in ("<script>", "<b>bold", "</li><i>", "<iframe>", "<img"):
        assert raw not in page
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page and "&lt;b&gt;bold&lt;/b&gt;" in page
    assert "a&amp;b" in page and "&lt;iframe&gt;" in page


def test_a_plain_calibration_is_still_exported_as_before():
    header = to_c(_calibration())
    assert header.startswith("/* imucalib calibration: method plain, model linear, created 2026-01-01T00:00:00Z\n")
    assert np.isfinite(linear_truth().accelerometer.scale).all()
