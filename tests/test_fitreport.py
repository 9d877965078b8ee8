"""The typed fit report: records by stage, the file's flat ``fit`` object written from them and read back into
them, and files of the previous format version (same content) still loading."""

import json
import warnings
from pathlib import Path

import pytest

from imucalib.calibration import FORMAT_VERSION, Calibration
from imucalib.fitreport import (
    AccelerometerReport,
    FitReport,
    GyroscopeReport,
    MagnetometerReport,
    SegmentationReport,
    VerdictReport,
    declarations,
)
from imucalib.recording import ImucalibWarning
from imucalib.reportfields import FIELDS

#: a calibration file written by the version before the typed report (format version 1)
V1 = Path(__file__).resolve().parent / "data" / "calibration_v1.json"


def test_a_version_1_file_loads_into_the_records_and_writes_the_same_fit():
    doc = json.loads(V1.read_text(encoding="utf-8"))
    assert doc["format_version"] == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImucalibWarning)  # every key of the old file is declared
        cal = Calibration.load(V1)
    fit = cal.fit
    assert isinstance(fit, FitReport) and fit.extra == {}
    assert fit.verdict.level == doc["fit"]["verdict"] and fit.verdict.reasons == doc["fit"]["verdict_reasons"]
    assert fit.poses.intervals == doc["fit"]["intervals"]
    assert fit.poses.static_intervals == len(doc["fit"]["intervals"])
    assert fit.accelerometer.residual_rms == doc["fit"]["accelerometer_residual_rms"]
    assert fit.magnetometer.dip_deg == doc["fit"]["magnetometer_dip_deg"]
    # a field written as null stays given (and written), one never given stays out
    assert doc["fit"]["magnetometer_field_error"] is None and "field_error" in fit.magnetometer.given
    assert "magnetometer_error" not in doc["fit"] and "error" not in fit.magnetometer.given
    # the rotations left out by index: integers in the record, their texts in the file (JSON's keys)
    left = fit.gyroscope.rotations_left_out
    assert left and {str(k): v for k, v in left.items()} == doc["fit"]["rotations_left_out"]
    assert all(isinstance(k, int) for k in left)
    again = json.loads(cal.to_json())
    assert again["format_version"] == FORMAT_VERSION == 2
    assert again["fit"] == doc["fit"]
    assert {k: v for k, v in again.items() if k != "format_version"} == \
        {k: v for k, v in doc.items() if k != "format_version"}


def test_the_flat_form_round_trips_and_reads_as_a_mapping():
    flat = {"static_intervals": 3, "verdict": "suspect", "verdict_reasons": ["a reason"],
            "magnetometer_field_error": None, "accelerometer_residual_rms": 0.01}
    report = FitReport.from_flat(flat)
    assert report.to_flat() == flat and report == flat and dict(report) == flat
    assert report.poses == SegmentationReport(static_intervals=3)
    assert report.verdict == VerdictReport(level="suspect", reasons=["a reason"])
    assert report.gyroscope.angle_error_mean_deg is None and "gyroscope_angle_error_mean_deg" not in report
    assert report["verdict"] == "suspect" and len(report) == 5
    with pytest.raises(KeyError):
        report["gyroscope_angle_error_mean_deg"]


def test_records_are_added_field_by_field():
    report = FitReport.of(SegmentationReport(static_intervals=4), VerdictReport(level="accepted"))
    report = report.add(VerdictReport(reasons=[]), AccelerometerReport(residual_rms=0.5))
    assert report.to_flat() == {"static_intervals": 4, "accelerometer_residual_rms": 0.5, "verdict": "accepted",
                                "verdict_reasons": []}
    assert report.add(FitReport.of(MagnetometerReport(error="no field"))).magnetometer.error == "no field"
    assert report.verdict.with_(level="rejected").level == "rejected"


def test_the_flat_table_is_derived_from_the_records():
    assert [(f.name, f.unit, f.meaning, f.group) for f in FIELDS] == list(declarations())
    assert len(FIELDS) > 80 and len({f.name for f in FIELDS}) == len(FIELDS)


def test_a_mapping_by_index_is_integers_in_the_record_and_texts_in_the_file():
    report = FitReport.of(GyroscopeReport(rotations_left_out={12: "a spike", 3: "a gap"}))
    assert report.to_flat() == {"rotations_left_out": {"12": "a spike", "3": "a gap"}}
    assert report["rotations_left_out"] == {"12": "a spike", "3": "a gap"}
    back = FitReport.from_flat(json.loads(json.dumps(report.to_flat())))
    assert back.gyroscope.rotations_left_out == {12: "a spike", 3: "a gap"} and back == report


def test_unknown_keys_are_kept_in_extra_and_written_back_after_the_records():
    report = FitReport.from_flat({"a_future_figure": [1, 2], "verdict": "accepted"})
    assert report.extra == {"a_future_figure": [1, 2]} and report.verdict.level == "accepted"
    assert list(report.to_flat()) == ["verdict", "a_future_figure"]
    assert FitReport.undeclared({"a_future_figure": 1, "verdict": "x"}) == ["a_future_figure"]
