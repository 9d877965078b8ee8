"""The verdict on the command line: printed first, exit 3 when rejected, apply/export refusing, reports, Monte Carlo.

Also the Ferraris options --turn-angle and --sections.
"""

import json
from pathlib import Path

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.cli import EXIT_REJECTED, main
from imucalib.io import write_csv
from imucalib.scenarios import ferraris_session, session
from synth import linear_truth

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "xsens_imu_tk"


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def ferraris_csv(tmp_path_factory):
    """A simulated Ferraris session (six faces, a 360° turn about each axis) as a CSV of raw counts."""
    rec, _, _ = ferraris_session(linear_truth(), 5)
    path = tmp_path_factory.mktemp("ferraris") / "ferraris.csv"
    write_csv(path, rec)
    return path


@pytest.fixture(scope="module")
def calibrations(ferraris_csv, tmp_path_factory):
    """An accepted calibration (the known 360°) and a rejected one (told 180°), both written by calibrate."""
    d = tmp_path_factory.mktemp("cal")
    assert main(["calibrate", str(ferraris_csv), "--method", "ferraris", "-o", str(d / "good.json"), "--json"]) == 0
    assert main(["calibrate", str(ferraris_csv), "--method", "ferraris", "--turn-angle", "180",
                 "-o", str(d / "rejected.json"), "--json"]) == EXIT_REJECTED
    return d / "good.json", d / "rejected.json"


def test_exit_code_constant():
    from imucalib.cli._common import EXIT_REJECTED as common

    assert common == EXIT_REJECTED == 3


def test_wrong_turn_angle_is_rejected_with_exit_3_and_the_file_marked(capsys, tmp_path, ferraris_csv):
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--method", "ferraris", "--turn-angle", 180,
                         "-o", tmp_path / "c.json", "--report", tmp_path / "r.html")
    assert code == 3
    lines = out.splitlines()
    assert lines[0] == "verdict: REJECTED"  # before the parameters
    assert lines[1].startswith("  - ") and out.index("verdict: REJECTED") < out.index("method: ferraris")
    assert "known angle 180°" in out  # the known-turns check names the wrong angle
    assert "written all the same" in err and str(tmp_path / "c.json") in err
    cal = Calibration.load(tmp_path / "c.json")  # written, and marked
    assert cal.fit["verdict"] == "rejected" and cal.fit["turn_angle_deg"] == 180
    assert any("known angle 180°" in r for r in cal.fit["verdict_reasons"])
    page = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "verdict-rejected" in page and "Verdict: REJECTED" in page and "#c62828" in page
    assert page.index("Verdict: REJECTED") < page.index("<h2>Fit</h2>")  # at the top
    assert "known angle 180°" in page
    # --json: the calibration on stdout (verdict in fit), exit 3, the reasons on stderr
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--method", "ferraris", "--turn-angle", 180, "--json")
    assert code == 3
    doc = json.loads(out)
    assert doc["fit"]["verdict"] == "rejected" and doc["fit"]["verdict_reasons"]
    assert "the calibration is rejected" in err and "known angle 180°" in err


def test_accepted_calibration_prints_its_verdict_first(capsys, tmp_path, ferraris_csv):
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--method", "ferraris", "--turn-angle", 360,
                         "--report", tmp_path / "r.html")
    assert code == 0, err
    assert out.splitlines()[0] == "verdict: ACCEPTED"
    assert "  verdict" not in out  # not repeated among the fit figures
    page = (tmp_path / "r.html").read_text(encoding="utf-8")
    assert "verdict-accepted" in page and "Verdict: ACCEPTED" in page


def test_xsens_with_a_gravity_typo_is_rejected(capsys, tmp_path):
    if not DATA.is_dir():
        pytest.skip("../shared/data/xsens_imu_tk not present (fresh clone): real-data test skipped")
    code, out, err = run(capsys, "calibrate", DATA / "xsens_acc.mat", DATA / "xsens_gyro.mat", "--reader", "imutk",
                         "--gravity", "9.18", "-o", tmp_path / "x.json")
    assert code == 3
    assert out.startswith("verdict: REJECTED\n  - the declared gravity 9.18 m/s² is outside")
    assert "written all the same" in err
    assert Calibration.load(tmp_path / "x.json").fit["verdict"] == "rejected"


def test_apply_and_export_refuse_a_rejected_calibration_unless_forced(capsys, tmp_path, ferraris_csv, calibrations):
    good, rejected = calibrations
    code, out, err = run(capsys, "apply", rejected, ferraris_csv, "-o", tmp_path / "o.csv")
    assert code == 2 and out == "" and not (tmp_path / "o.csv").exists()
    assert "was rejected when it was made" in err and "known angle 180°" in err and "--force" in err
    code, out, err = run(capsys, "export", rejected, "-o", tmp_path / "c.h")
    assert code == 2 and "was rejected" in err and not (tmp_path / "c.h").exists()
    code, out, err = run(capsys, "apply", rejected, ferraris_csv, "-o", tmp_path / "o.csv", "--force", "--json")
    assert code == 0, err
    assert json.loads(out)["verdict"] == "rejected" and (tmp_path / "o.csv").exists()
    assert "warning" in err and "--force" in err
    code, out, err = run(capsys, "export", rejected, "--force")
    assert code == 0 and "imucalib_apply" in out and "warning" in err
    # accepted: no warning
    code, out, err = run(capsys, "apply", good, ferraris_csv, "-o", tmp_path / "g.csv", "--json")
    assert code == 0 and err == "" and json.loads(out)["verdict"] == "accepted"


def test_suspect_and_older_calibrations_are_used(capsys, tmp_path, ferraris_csv, calibrations):
    good, _ = calibrations
    doc = json.loads(good.read_text())
    doc["fit"].update(verdict="suspect", verdict_reasons=["a reason to look twice"])
    (tmp_path / "suspect.json").write_text(json.dumps(doc))
    code, out, err = run(capsys, "apply", tmp_path / "suspect.json", ferraris_csv, "-o", tmp_path / "s.csv")
    assert code == 0 and (tmp_path / "s.csv").exists()
    assert "warning" in err and "suspect" in err and "a reason to look twice" in err
    code, out, err = run(capsys, "export", tmp_path / "suspect.json")
    assert code == 0 and "suspect" in err
    for key in ("verdict", "verdict_reasons", "verdict_notes"):
        doc["fit"].pop(key, None)
    (tmp_path / "old.json").write_text(json.dumps(doc))  # a file from before verdicts
    code, out, err = run(capsys, "apply", tmp_path / "old.json", ferraris_csv, "-o", tmp_path / "old.csv")
    assert code == 0 and err == ""
    code, out, err = run(capsys, "export", tmp_path / "old.json")
    assert code == 0 and err == ""


def test_ferraris_options_need_the_ferraris_method(capsys, tmp_path, ferraris_csv):
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--turn-angle", "180", "--method", "tedaldi2014")
    assert code == 2 and "--turn-angle applies to --method ferraris only, not tedaldi2014" in err
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--turn-angle", "360", "--json")
    assert code in (0, 3) and json.loads(out)["method"] == "ferraris"  # without --method they choose it
    (tmp_path / "s.json").write_text("{}")
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--method", "six_position", "--sections",
                         tmp_path / "s.json")
    assert code == 2 and "--sections applies to --method ferraris only" in err
    code, out, err = run(capsys, "calibrate", ferraris_csv, "--turn-angle", "90", "--sections", tmp_path / "s.json",
                         "--method", "ellipsoid")
    assert code == 2 and "--turn-angle and --sections apply to --method ferraris only" in err


@pytest.fixture(scope="module")
def handheld_ferraris(tmp_path_factory):
    """A hand-held Ferraris session without tremor, and its true named sections."""
    sim = session("handheld", rng=1, procedure="ferraris", tremor=0)
    d = tmp_path_factory.mktemp("handheld")
    write_csv(d / "rec.csv", sim.recording)
    (d / "sections.json").write_text(json.dumps(sim.options["sections"]))
    return d / "rec.csv", d / "sections.json", sim.options["sections"]


def test_sections_from_a_file(capsys, tmp_path, handheld_ferraris):
    rec, sections, truth = handheld_ferraris
    code, out, err = run(capsys, "calibrate", rec, "--method", "ferraris", "--sections", sections,
                         "-o", tmp_path / "c.json")
    assert code in (0, 3), err
    assert out.startswith("verdict: ")
    fit = Calibration.load(tmp_path / "c.json").fit
    assert fit["sections"] == "given"
    assert fit["faces"]["+x"] == truth["x_p"] and fit["faces"]["-z"] == truth["z_a"]
    assert {tuple(t[k] for k in ("start", "axis")) for t in fit["turn_sections"]} == {
        (truth[f"{a}_rot"][0], i) for i, a in enumerate("xyz")}


@pytest.mark.parametrize(("text", "message"), [
    ("{not json", "not valid JSON"),
    ("[1, 2]", "expected a JSON object"),
    ('{"x_p": [0, 10]}', "missing y_p, z_p, x_a, y_a, z_a, x_rot, y_rot, z_rot"),
    ("FULL+extra", "unknown extra"),
    ("FULL+bad", "'y_rot' must be [start, stop]"),
    ("[" * 10_000 + "]" * 10_000, "nested more than 64 levels deep"),
    ('{"a":' * 10_000 + "1" + "}" * 10_000, "nested more than 64 levels deep"),
    ('{"x_p": [0, NaN]}', "NaN is not a JSON number"),
    ("\x00\xff", "not a text file"),
    (" " * 70_000, "larger than 64 kB"),
], ids=lambda v: v[:30] if isinstance(v, str) else None)
def test_bad_sections_files_give_clear_errors(capsys, tmp_path, handheld_ferraris, text, message):
    rec, _, truth = handheld_ferraris
    if text.startswith("FULL"):
        doc = dict(truth)
        if text.endswith("extra"):
            doc["extra"] = [0, 1]
        else:
            doc["y_rot"] = [5, "ten"]
        text = json.dumps(doc)
    (tmp_path / "s.json").write_bytes(text.encode("latin-1"))
    code, out, err = run(capsys, "calibrate", rec, "--method", "ferraris", "--sections", tmp_path / "s.json")
    assert code == 2 and out == ""
    assert f"--sections {tmp_path / 's.json'}" in err and message in err, err
    assert "Traceback" not in err and len(err) < 1000
    code, out, err = run(capsys, "calibrate", rec, "--method", "ferraris", "--sections", tmp_path / "none.json")
    assert code == 2 and "file not found" in err


def test_montecarlo_counts_verdicts(capsys):
    code, out, err = run(capsys, "montecarlo", "--scenario", "handheld", "--method", "tedaldi2014", "--runs", 2,
                         "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert set(doc["verdicts"]) == {"accepted", "suspect", "rejected"}
    assert sum(doc["verdicts"].values()) == doc["runs"] - len(doc["failures"]) == 2
    code, out, err = run(capsys, "montecarlo", "--scenario", "handheld", "--method", "tedaldi2014", "--runs", 2)
    assert code == 0, err
    counts = ", ".join(f"{n} {level}" for level, n in doc["verdicts"].items())
    assert f"verdicts: {counts}" in out


def test_report_without_a_verdict_has_no_banner(tmp_path):
    from imucalib.report import html_report

    page = html_report(linear_truth(), tmp_path / "r.html").read_text(encoding="utf-8")
    assert "class='verdict" not in page
    cal = linear_truth().with_(fit={"verdict": "suspect", "verdict_reasons": ["look <here>"]})
    page = html_report(cal, tmp_path / "s.html").read_text(encoding="utf-8")
    assert "verdict-suspect" in page and "Verdict: SUSPECT" in page and "look &lt;here&gt;" in page
    assert np.all([c in page for c in ("#e6f4ea", "#fff4e0", "#fdecea")])
