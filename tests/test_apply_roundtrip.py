"""``imucalib apply`` copies every input column byte for byte and only adds the calibrated columns."""

import json
import subprocess
import warnings

import numpy as np
import pytest

from imucalib.calibration import Calibration
from imucalib.io import read, write_csv
from imucalib.models import TriadModel
from imucalib.recording import ImucalibWarning, Recording
from imucalib.scenarios.handheld import consumer_truth

EUROC_HEADER = ("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
                "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]")
T0_NS = 1403636579758555392  # EuRoC MH_01's first IMU stamp


def _si_calibration() -> Calibration:
    """A calibration of an IMU whose raw readings are already in m/s² and rad/s (as EuRoC's are)."""
    rng = np.random.default_rng(5)
    acc = TriadModel(shape="upper", misalignment=np.array([[1, 0.004, -0.002], [0, 1, 0.003], [0, 0, 1.0]]),
                     scale=1 + rng.uniform(-0.01, 0.01, 3), bias=rng.normal(0, 0.05, 3))
    gyro = TriadModel(shape="full", misalignment=np.eye(3) + rng.normal(0, 0.003, (3, 3)) * (1 - np.eye(3)),
                      scale=1 + rng.uniform(-0.01, 0.01, 3), bias=rng.normal(0, 0.002, 3),
                      g_sensitivity=rng.normal(0, 1e-4, (3, 3)))
    units = {"accelerometer": {"raw": "m/s^2", "calibrated": "m/s^2"},
             "gyroscope": {"raw": "rad/s", "calibrated": "rad/s"}}
    return Calibration(accelerometer=acc, gyroscope=gyro, units=units, method="test")


def _euroc(path, n=2000, crlf=False):
    """An EuRoC imu0/data.csv: integer ns stamps at 200 Hz, rates and accelerations with EuRoC's precision."""
    rng = np.random.default_rng(1)
    ns = T0_NS + np.arange(n, dtype=np.int64) * 5_000_000 + rng.integers(-20_000, 20_000, n)
    w = rng.normal(0, 0.3, (n, 3))
    a = rng.normal(0, 0.5, (n, 3)) + [9.0, 0.2, -3.1]
    end = "\r\n" if crlf else "\n"
    lines = [EUROC_HEADER] + [",".join([str(int(s))] + [repr(float(v)) for v in (*w[i], *a[i])])
                              for i, s in enumerate(ns)]
    path.write_bytes((end.join(lines) + end).encode())
    return path, ns, w, a


def _cli(capsys, *args):
    """``imucalib ARGS`` in this process (the command line and the API are one path), reported as a child's run."""
    from imucalib.cli import main

    capsys.readouterr()
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(["imucalib", *map(str, args)], code, out, err)


@pytest.mark.parametrize("crlf", [False, True])
def test_euroc_apply_round_trip(tmp_path, crlf, capsys):
    src, ns, w, a = _euroc(tmp_path / "data.csv", crlf=crlf)
    cal = _si_calibration()
    cal.save(tmp_path / "cal.json")
    out = tmp_path / "out.csv"
    done = _cli(capsys, "apply", tmp_path / "cal.json", src, "-o", out)
    assert done.returncode == 0, done.stderr
    original = src.read_bytes().split(b"\r\n" if crlf else b"\n")
    written = out.read_bytes().split(b"\r\n" if crlf else b"\n")
    assert len(written) == len(original)
    sep = b","
    # every original column, text for text: the header's names and every cell of every row
    for before, after in zip(original, written, strict=True):
        assert after.split(sep)[:7] == before.split(sep)[:7]
    head = written[0].decode().split(",")
    assert head[7:] == [f"acc_{x}_cal [m/s^2]" for x in "xyz"] + [f"gyro_{x}_cal [rad/s]" for x in "xyz"]
    stamps = [int(ln.split(sep)[0]) for ln in written[1:-1]]
    assert stamps == ns.tolist() and len(set(stamps)) == len(ns)  # exact, none shared
    # the calibrated columns are Calibration.apply of the values read
    rec = read(src)
    expected = cal.apply(rec)
    cells = np.array([[float(c) for c in ln.split(sep)[7:]] for ln in written[1:-1]])
    np.testing.assert_allclose(cells[:, :3], expected.acc, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cells[:, 3:], expected.gyro, rtol=0, atol=1e-9)
    np.testing.assert_allclose(expected.acc, cal.accelerometer.forward(a), rtol=0, atol=1e-12)
    # the output is readable again, with the same samples and the same times
    back = read(out)
    np.testing.assert_array_equal(back.acc, rec.acc)
    np.testing.assert_array_equal(back.gyro, rec.gyro)
    np.testing.assert_array_equal(back.t, rec.t)
    assert back.metadata["t0"] == ns[0]
    np.testing.assert_allclose(back.extra["gyro_z_cal [rad/s]"], expected.gyro[:, 2], rtol=0, atol=1e-9)


def test_every_kind_of_column_is_copied_exactly(tmp_path):
    """IDs beyond float precision, text with the separator in quotes, duplicate names, precision, a preamble."""
    n = 300
    rng = np.random.default_rng(2)
    ids = 12345678901234567 + np.arange(n) * 7  # 17 digits: float64 would merge neighbours
    lines = ["# logger v2", "Fs,100", "id;time;ax;ay;az;gx;gy;gz;note;ax;gain"]
    for i in range(n):
        cells = [str(ids[i]), f"{i * 0.01:.2f}"] + [f"{v:.6f}".replace(".", ",") for v in rng.normal(0, 1, 6)]
        note = '"a;b ""quoted"""' if i % 50 == 7 else f"n{i}"
        cells += [note, "0,1234567890123456789", "2,500"]
        lines.append(";".join(cells))
    src = tmp_path / "in.csv"
    src.write_text("\n".join(lines) + "\n", encoding="utf-8")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        rec = read(src)
    assert rec.extra["id"].dtype == np.int64 and rec.extra["id"][-1] == ids[-1]
    assert rec.extra["note"][7] == 'a;b "quoted"'
    cal = Calibration()
    out = cal.apply(rec)
    write_csv(tmp_path / "out.csv", rec, out.acc, out.gyro)
    written = (tmp_path / "out.csv").read_text(encoding="utf-8").split("\n")
    assert written[:2] == lines[:2]
    assert written[2] == lines[2] + ";acc_x_cal [m/s^2];acc_y_cal [m/s^2];acc_z_cal [m/s^2]" \
        ";gyro_x_cal [rad/s];gyro_y_cal [rad/s];gyro_z_cal [rad/s]"
    for before, after in zip(lines[3:], written[3:], strict=False):
        assert after.startswith(before + ";")
        added = after[len(before) + 1:].split(";")
        assert len(added) == 6 and all("," in c or c.lstrip("-").isdigit() for c in added)  # decimal commas
    with pytest.warns(ImucalibWarning, match="skipped 2 lines before the header"):
        back = read(tmp_path / "out.csv")
    np.testing.assert_array_equal(back.acc, rec.acc)
    np.testing.assert_allclose(back.extra["acc_y_cal [m/s^2]"], out.acc[:, 1], rtol=0, atol=1e-12)


def test_headerless_input_gets_a_header_naming_what_was_read(tmp_path):
    n = 50
    rng = np.random.default_rng(3)
    data = rng.normal(0, 1, (n, 6))
    lines = [" ".join(f"{v:.5f}" for v in row) for row in data]
    src = tmp_path / "log.txt"
    src.write_text("\n".join(lines) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ImucalibWarning)
        rec = read(src, rate=50.0)
    cal = Calibration()
    out = cal.apply(rec)
    write_csv(tmp_path / "out.txt", rec, out.acc, out.gyro)
    written = (tmp_path / "out.txt").read_text().split("\n")
    assert written[0].split() == ["ax[counts]", "ay[counts]", "az[counts]", "gx[counts]", "gy[counts]",
                                  "gz[counts]", "acc_x_cal[m/s^2]", "acc_y_cal[m/s^2]", "acc_z_cal[m/s^2]",
                                  "gyro_x_cal[rad/s]", "gyro_y_cal[rad/s]", "gyro_z_cal[rad/s]"]
    for before, after in zip(lines, written[1:], strict=False):
        assert after.startswith(before + " ")
    back = read(tmp_path / "out.txt", rate=50.0)
    np.testing.assert_array_equal(back.acc, rec.acc)
    np.testing.assert_allclose(back.extra["gyro_x_cal[rad/s]"], out.gyro[:, 0], rtol=0, atol=1e-12)


def test_a_changed_recording_is_written_from_its_values(tmp_path):
    """Once the samples differ from the file's, its text is not copied: the values are written, exactly."""
    src, ns, w, a = _euroc(tmp_path / "data.csv", n=100)
    rec = read(src)
    changed = rec.in_si()  # same arrays: still the file's samples
    write_csv(tmp_path / "same.csv", changed)
    assert (tmp_path / "same.csv").read_bytes() == src.read_bytes()
    rec.acc[0, 0] += 1.0
    write_csv(tmp_path / "values.csv", rec)
    text = (tmp_path / "values.csv").read_text().split("\n")
    assert text[0] == EUROC_HEADER
    assert [int(ln.split(",")[0]) for ln in text[1:-1]] == ns.tolist()  # integer stamps restored exactly
    back = read(tmp_path / "values.csv")
    np.testing.assert_array_equal(back.acc, rec.acc)  # shortest round-trip text: every double exact
    np.testing.assert_array_equal(back.gyro, rec.gyro)


def test_a_file_changed_after_reading_is_not_copied(tmp_path):
    src, ns, w, a = _euroc(tmp_path / "data.csv", n=100)
    rec = read(src)
    lines = src.read_text().split("\n")
    cells = lines[1].split(",")
    cells[1] = "0.5"  # another value, another size
    lines[1] = ",".join(cells)
    src.write_text("\n".join(lines))
    write_csv(tmp_path / "out.csv", rec)
    back = read(tmp_path / "out.csv")
    assert back.gyro[0, 0] == w[0, 0] != 0.5  # the recording's sample, not the file's new one
    np.testing.assert_array_equal(back.acc, rec.acc)
    np.testing.assert_array_equal(back.t, rec.t)


def test_apply_handles_a_simulated_counts_session(tmp_path, capsys):
    """The CLI on raw counts with a time column in seconds: columns copied, calibrated ones added."""
    truth = consumer_truth(np.random.default_rng(4))
    rng = np.random.default_rng(4)
    n = 500
    rec = Recording(np.round(np.arange(n) * 0.01 + rng.uniform(0, 1e-3, n), 6),
                    np.round(rng.normal(0, 3000, (n, 3))), np.round(rng.normal(0, 200, (n, 3))))
    write_csv(tmp_path / "raw.csv", rec)
    truth.save(tmp_path / "cal.json")
    done = _cli(capsys, "apply", tmp_path / "cal.json", tmp_path / "raw.csv", "-o", tmp_path / "out.csv", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["samples"] == n
    raw = (tmp_path / "raw.csv").read_text().split("\n")
    out = (tmp_path / "out.csv").read_text().split("\n")
    assert all(o.startswith(r + ",") for r, o in zip(raw[1:-1], out[1:-1], strict=True))
    back = read(tmp_path / "out.csv")
    expected = truth.apply(read(tmp_path / "raw.csv"))
    got = np.column_stack([back.extra[f"gyro_{x}_cal [rad/s]"] for x in "xyz"])
    np.testing.assert_allclose(got, expected.gyro, rtol=0, atol=1e-12)
