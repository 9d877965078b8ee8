"""Command line: ``imucalib <command>``; thin commands over the library.

Every command has ``--help``. With ``--json`` the machine-readable result is
the only thing printed on stdout; errors go to stderr with a non-zero exit.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import __version__
from .calibration import Calibration
from .recording import STANDARD_GRAVITY, ImucalibWarning, Recording

EXIT_ERROR = 2


class CliError(Exception):
    """An error reported to the user as one line on stderr."""


# --------------------------------------------------------------------- helpers
def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number; got {text!r}") from None
    if not (np.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number; got {text!r}")
    return v


def _add_reader_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("reading the data")
    g.add_argument("--reader", choices=("csv", "imutk", "mat", "rosbag", "session"),
                   help="input format (default: guessed from the file)")
    g.add_argument("--topic", help="ROS bags: the sensor_msgs/Imu topic (needed when there are several)")
    g.add_argument("--columns", help="comma-separated column names or 0-based indices in the "
                   "order t,ax,ay,az,gx,gy,gz ('-' for no time column)")
    g.add_argument("--acc-unit", choices=("counts", "g", "m/s^2"),
                   help="accelerometer unit of the input (default: from the header, else counts)")
    g.add_argument("--gyro-unit", choices=("counts", "deg/s", "rad/s"),
                   help="gyroscope unit of the input (default: from the header, else counts)")
    g.add_argument("--time-unit", choices=("s", "ms", "us", "ns"),
                   help="unit of the time column (default: from the header or its values)")
    g.add_argument("--rate", type=_positive_float, help="sampling rate [Hz] when there is no time column")
    g.add_argument("--variable", help="name of the matrix in a MATLAB .mat file")


def _read(args: argparse.Namespace, paths: Sequence[str]):
    from .io.rosbag import is_rosbag

    if args.reader == "session" or (args.reader is None and len(paths) == 1 and Path(paths[0]).is_dir()
                                    and not is_rosbag(Path(paths[0]))):
        from .scenarios import read_session

        return read_session(paths[0])
    from .io import read

    columns = args.columns.split(",") if args.columns else None
    return read(
        list(paths), reader=args.reader, columns=columns, acc_unit=args.acc_unit,
        gyro_unit=args.gyro_unit, rate=args.rate, variable=args.variable,
        time_unit=args.time_unit, topic=args.topic,
    )


def _read_recording(args: argparse.Namespace, paths: Sequence[str]) -> Recording:
    """The recording in ``paths`` (a simulated session's main recording); a clear error for turntable aggregates."""
    data = _read(args, paths)
    rec = getattr(data, "recording", data)
    if not isinstance(rec, Recording):
        raise CliError(f"imucalib {args.command} needs a recording of samples; {paths[0]} holds turntable "
                       "aggregates (a wang2019 session), which only 'calibrate --method wang2019' reads")
    return rec


def _progress(enabled: bool):
    if not enabled:
        return None
    start = time.perf_counter()

    def say(msg: str) -> None:
        print(f"[{time.perf_counter() - start:6.2f} s] {msg}", file=sys.stderr, flush=True)

    return say


def _print_calibration(cal: Calibration) -> None:
    """The calibration for a person: every parameter, with ± its 1σ error where the method gives one."""
    unc = (cal.fit or {}).get("uncertainty") or {}

    def pm(name: str, value: float, fmt: str = ".7g") -> str:
        s = unc.get(name)
        return f"{value:{fmt}}" + (f" ± {s:.2g}" if s is not None and np.isfinite(s) else "")

    def vec(prefix: str, key: str, values) -> str:
        return "  ".join(pm(f"{prefix}.{key}.{ax}", v) for ax, v in zip("xyz", values, strict=True))

    def matrix(prefix: str, key: str, m) -> str:
        cells = [[pm(f"{prefix}.{key}.{'xyz'[i]}{'xyz'[j]}", v, " .7g") for j, v in enumerate(row)]
                 for i, row in enumerate(m)]
        width = max(len(c) for row in cells for c in row)
        return "\n".join("    [" + "  ".join(c.ljust(width) for c in row) + "]" for row in cells)

    a, g = cal.accelerometer, cal.gyroscope
    ua, ug = cal.units["accelerometer"]["raw"], cal.units["gyroscope"]["raw"]
    print(f"method: {cal.method}   model: {cal.model}   gravity: {cal.gravity} m/s^2")
    if unc:
        print("(± : 1σ standard error of the fit)")
    for prefix, t, unit, cal_unit, formula in (
            ("accelerometer", a, ua, "m/s^2", "a = T_a · f(u − b)"),
            ("gyroscope", g, ug, "rad/s", "ω = T_g · f(u − b − G·a)")):
        print(f"{prefix}  {formula}")
        print(f"  misalignment T:\n{matrix(prefix, 'misalignment', t.misalignment)}")
        print(f"  scale k1 [{cal_unit} per {unit}]: {vec(prefix, 'scale', t.scale)}")
        if not t.is_linear:
            print(f"  scale k2: {vec(prefix, 'scale_quadratic', t.scale_quadratic)}")
            print(f"  scale k3: {vec(prefix, 'scale_cubic', t.scale_cubic)}")
        print(f"  bias b [{unit}]: {vec(prefix, 'bias', t.bias)}")
        if np.any(t.output_bias):
            print(f"  output bias d [{cal_unit}]: {vec(prefix, 'output_bias', t.output_bias)}")
        if np.any(t.g_sensitivity):
            print(f"  g-sensitivity G:\n{matrix(prefix, 'g_sensitivity', t.g_sensitivity)}")
    if cal.lever_arm is not None:
        print("lever arm r [m]: " + "  ".join(pm(f"lever_arm.{ax}", v, ".6g")
                                               for ax, v in zip("xyz", cal.lever_arm, strict=True)))
    if cal.fit:
        print("fit:")
        for k, v in cal.fit.items():
            if k == "intervals":
                print(f"  intervals: {len(v)} (sample ranges in the JSON)")
            elif k == "uncertainty":
                continue
            elif k == "pose_coverage":
                print("  pose_coverage (gravity component, min..max): "
                      + "  ".join(f"{a} {lo:+.2f}..{hi:+.2f}" for a, (lo, hi) in v.items()))
            elif k == "quality_flags":
                for flag in v:
                    print(f"  quality flag: {flag}")
            else:
                print(f"  {k}: {v:.6g}" if isinstance(v, float) else f"  {k}: {v}")


# -------------------------------------------------------------------- commands
def cmd_calibrate(args: argparse.Namespace) -> int:
    from .methods import calibrate

    say = _progress(not args.json and sys.stderr.isatty())
    data = _read(args, args.data)
    options = {}
    if args.init_static is not None:
        options["init_static"] = args.init_static
    if args.detector is not None:
        options["detector"] = args.detector
    if say is not None:
        options["progress"] = say
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ImucalibWarning)
        cal = calibrate(data, method=args.method, model=args.model, gravity=args.gravity, **options)
    for w in caught:  # shown as usual, and kept for the report
        warnings.showwarning(w.message, w.category, w.filename, w.lineno)
    if args.output:
        cal.save(args.output)
    from .recording import Interval

    rec = data if not hasattr(data, "positions_acc") else None
    rec = getattr(rec, "recording", rec)
    ivs = [Interval(a, b) for a, b in cal.fit.get("intervals", [])]
    if args.plot:
        from .report import plot_fit

        if rec is None or not ivs:
            raise CliError("this method's data has no static poses to plot")
        plot_fit(cal, rec, ivs, args.plot)
    if args.report:
        from .report import html_report

        html_report(cal, args.report, recording=rec, intervals=ivs,
                    notes=[str(w.message) for w in caught if issubclass(w.category, ImucalibWarning)])
    if args.json:
        print(cal.to_json())
    else:
        _print_calibration(cal)
        if args.output:
            print(f"saved to {args.output}")
        if args.plot:
            print(f"plot written to {args.plot}")
        if args.report:
            print(f"report written to {args.report}")
    return 0


def cmd_apply(args: argparse.Namespace) -> int:
    from .io import write_csv
    from .io.rosbag import is_rosbag

    cal = Calibration.load(args.calibration)
    if (args.reader == "rosbag" or is_rosbag(Path(args.data))) and Path(args.output).suffix.lower() != ".csv":
        from .io.rosbag import write_calibrated_bag

        summary = write_calibrated_bag(args.data, args.output, cal, topic=args.topic)
        summary["calibration"] = str(args.calibration)
        if args.json:
            print(json.dumps(summary))
        else:
            print(f"wrote {args.output}: {summary['corrected']} {summary['topic']} messages calibrated, "
                  f"{summary['copied']} other messages copied unchanged")
        return 0
    rec = _read_recording(args, [args.data])
    out = cal.apply(rec)
    write_csv(args.output, rec, calibrated_acc=out.acc, calibrated_gyro=out.gyro)
    summary = {"input": str(args.data), "output": str(args.output), "samples": len(rec),
               "calibration": str(args.calibration), "method": cal.method}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote {len(rec)} calibrated samples to {args.output}")
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from .compare import compare

    say = _progress(not args.json and sys.stderr.isatty())
    rec = _read_recording(args, args.data)
    methods = args.methods.split(",") if args.methods else None
    result = compare(rec, gravity=args.gravity, methods=methods,
                     folds=None if args.folds == 0 else args.folds, progress=say)
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"{result['static_intervals']} static intervals; leave-one-pose-out over "
          f"{result['folds']} held-out poses")
    print(f"{'method':<14}{'model':<18}{'CV |a|-g RMS [m/s^2]':>22}{'CV angle mean [deg]':>22}")
    for row in result["methods"]:
        model = row["model"] or "-"
        if row.get("model_selected") and row["model_selected"] != row["model"]:
            model = f"{model}->{row['model_selected']}"
        if row["ok"]:
            print(f"{row['method']:<14}{model:<18}"
                  f"{row['cv_accelerometer_residual_rms']:>22.5f}"
                  f"{row['cv_gyroscope_angle_error_mean_deg']:>22.4f}"
                  + (f"   ({row['cv_folds_skipped']} folds could not run)" if row["cv_folds_skipped"] else ""))
        else:
            print(f"{row['method']:<14}{model:<18}  cannot run: {row['reason']}")
    return 0


def cmd_validate(args: argparse.Namespace) -> int:
    """A calibration's fit figures on a recording it was not made from (no refit)."""
    from .metrics import fit_summary
    from .segment import detect_intervals

    cal = Calibration.load(args.calibration)
    rec = _read_recording(args, args.data)
    gravity = args.gravity or cal.gravity
    cal.check_units(rec)
    intervals = detect_intervals(rec, gravity)[0]
    fit = fit_summary(cal, rec, intervals, gravity)
    keys = ("accelerometer_residual_rms", "gyroscope_angle_error_mean_deg", "gyroscope_angle_error_max_deg")
    keys = (*keys, "temperature_c")
    result = {"calibration": str(args.calibration), "method": cal.method, "gravity": gravity,
              "static_intervals": fit["static_intervals"], **{k: fit.get(k) for k in keys},
              "at_calibration": {k: (cal.fit or {}).get(k) for k in ("static_intervals", *keys)}}
    if args.plot:
        from .report import plot_fit

        plot_fit(cal, rec, intervals, args.plot)
    if args.json:
        print(json.dumps(result))
        return 0
    then = result["at_calibration"]
    print(f"{cal.method} calibration on {len(intervals)} static poses of this recording (not refitted):")
    if fit.get("temperature_c") and (cal.fit or {}).get("temperature_c"):
        t_now, t_then = fit["temperature_c"][1], cal.fit["temperature_c"][1]
        print(f"  temperature {t_now:.1f} °C (at calibration {t_then:.1f} °C)"
              + ("  — more than 5 °C apart: biases may have drifted" if abs(t_now - t_then) > 5 else ""))
    for k, label, unit in ((keys[0], "‖a‖ − g RMS", "m/s^2"), (keys[1], "gyro angle error mean", "deg"),
                           (keys[2], "gyro angle error max", "deg")):
        now = result[k]
        if now is None:
            continue
        ref = f"   (at calibration {then[k]:.4g}: ×{now / then[k]:.2f})" if then.get(k) else ""
        print(f"  {label:<24}{now:10.4g} {unit}{ref}")
    if args.plot:
        print(f"plot written to {args.plot}")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    from .export import to_c

    cal = Calibration.load(args.calibration)
    text = to_c(cal, prefix=args.prefix, ctype="float" if args.float else "double")
    if args.output:
        Path(args.output).write_text(text, encoding="utf-8")
        print(f"wrote {args.output}: {args.prefix}_apply(acc_raw, gyro_raw, acc, gyro)")
    else:
        sys.stdout.write(text)
    return 0


def cmd_detect_fall(args: argparse.Namespace) -> int:
    from .methods.zhang2021 import detect_fall

    cal = Calibration.load(args.calibration)
    rec = _read_recording(args, [args.data])
    falls = detect_fall(cal, rec, threshold=args.threshold)
    out = {"threshold": args.threshold, "falls": [
        {"start": iv.start, "stop": iv.stop, "t_start": float(rec.t[iv.start]),
         "t_stop": float(rec.t[iv.stop - 1]), "duration": float(rec.t[iv.stop - 1] - rec.t[iv.start])}
        for iv in falls]}
    if args.json:
        print(json.dumps(out))
    else:
        print(f"{len(falls)} falling intervals (eq. 19 loss < {args.threshold} m/s^2)")
        for f in out["falls"]:
            print(f"  {f['t_start']:10.3f} s .. {f['t_stop']:10.3f} s  ({f['duration']:.3f} s)")
    return 0


def _noise_options(args: argparse.Namespace) -> dict | None:
    """``--noise-acc``/``--noise-gyro`` as a scenario's noise overrides (per sample, SI units)."""
    noise = {}
    if args.noise_acc is not None:
        noise["accelerometer"] = args.noise_acc
    if args.noise_gyro is not None:
        noise["gyroscope"] = args.noise_gyro
    return noise or None


def _simulate_wang(args: argparse.Namespace) -> int:
    from .scenarios.wang2019 import session

    sim = session(args.seed, turntable_error=args.turntable_error, noise=_noise_options(args),
                  dwell_s=args.dwell)
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    np.savetxt(out / "positions.csv", np.column_stack([sim.positions_acc, sim.positions_gyro]),
               delimiter=",", fmt="%.17g", header="ax,ay,az,gx,gy,gz", comments="")
    np.savetxt(out / "turns.csv", np.column_stack([sim.turn_sum, sim.turn_sum2, sim.turn_angle]),
               delimiter=",", fmt="%.17g",
               header="sum_x,sum_y,sum_z,sum2_x,sum2_y,sum2_z,angle", comments="")
    sim.truth.save(out / "truth.json")
    meta = {"format": "imucalib.session", "format_version": 1, "scenario": "wang2019",
            "seed": args.seed, "turntable_error": args.turntable_error,
            "latitude_deg": sim.latitude_deg, "options": sim.options,
            "files": {"positions.csv": "static position means [pulses/s]",
                      "turns.csv": "clockwise − counter-clockwise turn integrals"}}
    (out / "session.json").write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    summary = {"scenario": "wang2019", "seed": args.seed, "directory": str(out),
               "positions": len(sim.positions_acc), "turn_pairs": len(sim.turn_sum)}
    print(json.dumps(summary) if args.json else
          f"wrote the wang2019 session (seed {args.seed}) to {out}: {summary['positions']} "
          f"positions, {summary['turn_pairs']} turn pairs")
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    from .scenarios import session, write_session

    if args.scenario == "wang2019":
        return _simulate_wang(args)
    sim = session(args.scenario, rng=args.seed, noise=_noise_options(args))
    out = write_session(sim, args.output)
    summary = {"scenario": args.scenario, "seed": args.seed, "directory": str(out),
               "samples": len(sim.recording), "static": sum(s.kind == "static" for s in sim.segments),
               "weightless": len(sim.weightless), "tests": len(sim.tests), "noise": sim.noise}
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"wrote the {args.scenario} session (seed {args.seed}) to {out}: "
              f"{summary['samples']} RD1 samples, {summary['static']} static poses, "
              f"{summary['weightless']} weightless spins, {summary['tests']} test tosses")
    return 0


class _Bar:
    """A progress bar on stderr when it is a terminal; silent otherwise."""

    def __init__(self, label: str, enabled: bool) -> None:
        self.label, self.enabled, self.start = label, enabled, time.perf_counter()

    def __call__(self, done: int, total: int) -> None:
        if not self.enabled:
            return
        width = 30
        fill = int(width * done / total)
        print(f"\r{self.label} [{'#' * fill}{'.' * (width - fill)}] {done}/{total} "
              f"{time.perf_counter() - self.start:5.1f} s", end="", file=sys.stderr, flush=True)
        if done == total:
            print(file=sys.stderr)


def _print_wang_montecarlo(result: dict) -> None:
    """The Monte Carlo RMS errors per axis beside Wang 2019, Tables 2-3 (same column, same units)."""
    print(f"{result['runs']} runs of wang2019, turntable error {result['turntable_error']}, initial "
          f"values: {result['initial']}; divergent runs: {result['divergent_runs']}, failed: "
          f"{len(result['failures'])}")
    print(f"{'RMS error':<28}{'x / yx':>11}{'y / zx':>11}{'z / zy':>11}{'max':>11}{'paper max':>11}  ok")
    for key, rms in result["rms"].items():
        if rms is None:
            continue
        paper = result["paper_rms"][key]
        ok = "yes" if result["within_paper"][key] else "NO"
        print(f"{key:<28}" + "".join(f"{v:>11.3g}" for v in rms) + f"{max(rms):>11.3g}{max(paper):>11.3g}  {ok}")
    print("ok: the largest axis at or below the table's largest (which axis carries the larger error depends "
          "on the rotation plan, which the paper's text does not give)")


def cmd_montecarlo(args: argparse.Namespace) -> int:
    from .evaluate import montecarlo

    if args.scenario == "wang2019":
        if args.method != "wang2019":
            raise CliError("the wang2019 scenario holds turntable data: use --method wang2019")
        from .scenarios.wang2019 import montecarlo as wang_mc

        result = wang_mc(args.runs, turntable_error=args.turntable_error, seed=args.seed,
                         initial=args.initial, workers=args.workers, noise=_noise_options(args),
                         dwell_s=args.dwell)
        if args.json:
            print(json.dumps(result))
            return 0
        _print_wang_montecarlo(result)
        return 0
    if args.scenario == "qureshi2017":
        if args.method != "qureshi2017":
            raise CliError("the qureshi2017 scenario reproduces Qureshi 2017 §IV: use --method qureshi2017")
        from .scenarios.qureshi2017 import montecarlo as qureshi_mc

        result = qureshi_mc(args.runs, seed=args.seed, workers=args.workers)
        if args.json:
            print(json.dumps(result))
            return 0
        print(f"{result['runs']} runs of qureshi2017 (18 orientations, 2 s each at 100 Hz, Table II-like truth)")
        print(f"  RMS(|a| - g) over 92 fresh orientations: raw {result['raw_rms_g_mean']:.4g} g, calibrated "
              f"{result['calibrated_rms_g_mean']:.3g} g; reduction {result['reduction_fold_min']:.0f}-fold at least "
              "(paper: 0.0129 g -> 0.0014 g)")
        g = result["gyro_scale_rel_error_max"]
        print(f"  gyroscope scales, worst relative error: static-bias {g['static']:.2%}, dynamic {g['dynamic']:.2%} "
              "(paper: within 0.41 %)")
        return 0
    if _noise_options(args) is not None:
        raise CliError("--noise-acc/--noise-gyro apply to the wang2019 scenario here; for the others "
                       "write a session with `imucalib simulate --noise-…` and calibrate it")
    bar = _Bar(f"{args.method} on {args.scenario}", sys.stderr.isatty())
    result = montecarlo(args.scenario, args.method, model=args.model, runs=args.runs,
                        workers=args.workers, seed=args.seed, baseline=args.baseline,
                        progress=bar)
    if args.json:
        print(json.dumps(result))
        return 0
    print(f"{result['runs']} runs of {args.method} ({args.model or 'default model'}) on "
          f"{args.scenario}; {len(result['failures'])} failed")
    print(f"{'parameter':<36}{'truth':>14}{'mean':>14}{'std':>12}{'rms error':>12}")
    for p in result["parameters"]:
        if p["mean"] is None:
            continue
        print(f"{p['name']:<36}{p['truth']:>14.6g}{p['mean']:>14.6g}{p['std']:>12.3g}"
              f"{p['rms_error']:>12.3g}")
    for k, v in result["metrics"].items():
        print(f"{k}: {v}")
    for f in result["failures"]:
        print(f"seed {f['seed']}: {f['message']}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from .evaluate import reductions, sequence_metrics
    from .methods import calibrate
    from .scenarios import session

    say = _progress(not args.json and sys.stderr.isatty())
    t0 = time.perf_counter()
    if say:
        say("simulating the zhang2021 session (Table I truth, default noise)")
    sim = session("zhang2021", rng=args.seed)
    g = sim.truth.gravity
    if say:
        say("calibrating: tedaldi2014 (linear)")
    ted = calibrate(sim, method="tedaldi2014", gravity=g)
    if say:
        say("calibrating: zhang2021 linear")
    lin = calibrate(sim, method="zhang2021", model="linear", gravity=g)
    if say:
        say("calibrating: zhang2021 all")
    full = calibrate(sim, method="zhang2021", model="all", gravity=g)
    m_all = sequence_metrics(full, sim.tests)
    m_lin = sequence_metrics(lin, sim.tests, lever_arm=full.lever_arm)
    m_ted = sequence_metrics(ted, sim.tests, lever_arm=full.lever_arm)
    elapsed = time.perf_counter() - t0
    truth = sim.truth.parameters()
    est = {"linear": lin.parameters(), "all": full.parameters()}
    unc = full.fit.get("uncertainty", {})
    rows = [{"name": k, "truth": v, "linear": est["linear"].get(k), "all": est["all"].get(k),
             "all_std": unc.get(k)} for k, v in truth.items()]
    result = {
        "scenario": "zhang2021", "seed": args.seed, "seconds": round(elapsed, 3),
        "parameters": rows,
        "metrics": {
            "eq34_mean": {"tedaldi2014": float(np.mean(m_ted["eq34"])),
                          "linear": float(np.mean(m_lin["eq34"])),
                          "all": float(np.mean(m_all["eq34"]))},
            "eq35_mean": {"tedaldi2014": float(np.mean(m_ted["eq35"])),
                          "linear": float(np.mean(m_lin["eq35"])),
                          "all": float(np.mean(m_all["eq35"]))},
            **{f"all_vs_tedaldi2014_{k}": v for k, v in reductions(m_all, m_ted).items()},
        },
    }
    if args.json:
        print(json.dumps(result))
        return 0
    print("Zhang 2021 synthetic session (Table I truth): linear model vs the full model")
    print(f"{'parameter':<36}{'truth':>14}{'linear':>14}{'all':>14}{'± 1σ':>11}{'error/σ':>9}")
    within = []
    for r in rows:
        lv = "-" if r["linear"] is None else f"{r['linear']:.6g}"
        sd = r["all_std"]
        if sd is not None and np.isfinite(sd) and sd > 0:
            z = (r["all"] - r["truth"]) / sd
            within.append(abs(z) <= 2)
            tail = f"{sd:>11.2g}{z:>9.2f}"
        else:
            tail = f"{'-':>11}{'-':>9}"
        print(f"{r['name']:<36}{r['truth']:>14.6g}{lv:>14}{r['all']:>14.6g}{tail}")
    if within:
        print(f"the full model's reported 1σ errors: {sum(within)} of {len(within)} estimates within 2σ "
              "of the truth (about 95 % expected)")
    mt = result["metrics"]
    print("\ntest tosses (Zhang 2021 §IV-B):          tedaldi2014      linear         all")
    print(f"  eq. (34) weightless error [(m/s^2)^2] {mt['eq34_mean']['tedaldi2014']:>12.4g}"
          f"{mt['eq34_mean']['linear']:>12.4g}{mt['eq34_mean']['all']:>12.4g}")
    print(f"  eq. (35) gravity cosine              {mt['eq35_mean']['tedaldi2014']:>12.6f}"
          f"{mt['eq35_mean']['linear']:>12.6f}{mt['eq35_mean']['all']:>12.6f}")
    print(f"  reduction vs tedaldi2014: eq. (34) {mt['all_vs_tedaldi2014_eq34_reduction']:.2%}, "
          f"eq. (35) {mt['all_vs_tedaldi2014_eq35_reduction']:.2%} (paper: 64.12 %, 47.90 %)")
    print(f"done in {elapsed:.1f} s")
    return 0


def cmd_noise(args: argparse.Namespace) -> int:
    from .noise import kalibr_yaml, noise_parameters, random_walk_bound
    from .segment import find_initial_rest

    rec = _read_recording(args, args.data)
    if args.calibration:  # noise in SI units, through the calibration
        rec = Calibration.load(args.calibration).apply(rec)
    part = rec if args.whole else rec[find_initial_rest(rec)]
    result = {"seconds": part.duration, "samples": len(part), "rate_hz": part.rate}
    for name, x, unit in (("accelerometer", part.acc, part.acc_unit), ("gyroscope", part.gyro, part.gyro_unit)):
        p = noise_parameters(x, part.rate)
        result[name] = {"unit": unit, **{k: v.tolist() for k, v in p.items()},
                        "random_walk_bound": random_walk_bound(x, part.rate).tolist()}
    if args.kalibr:
        if (part.acc_unit, part.gyro_unit) != ("m/s^2", "rad/s"):
            raise CliError(f"the Kalibr file needs SI units; this recording is in {part.acc_unit} and "
                           f"{part.gyro_unit}: pass --calibration CALIBRATION.json (or read data in m/s^2, rad/s)")
        text, notes = kalibr_yaml(result["accelerometer"], result["gyroscope"], part.rate,
                                  topic=rec.metadata.get("topic") or "/imu0")
        Path(args.kalibr).write_text(text, encoding="utf-8")
        for n in notes:
            _show_warning(n, ImucalibWarning, "", 0)
        result["kalibr"] = str(args.kalibr)
    if args.plot:
        from .report import plot_allan

        plot_allan(part, args.plot)
    if args.json:
        print(json.dumps(result))
        return 0
    if args.plot:
        print(f"plot written to {args.plot}")
    if args.kalibr:
        print(f"Kalibr noise file written to {args.kalibr}")
    print(f"noise over {result['seconds']:.1f} s of rest ({result['samples']} samples, "
          f"{result['rate_hz']:.4g} Hz), Allan deviation (IEEE 952 slopes):")
    for name in ("accelerometer", "gyroscope"):
        r = result[name]
        u = r["unit"]
        print(f"  {name}: white noise {_triple(r['white_noise_density'])} {u}·√s "
              f"({_triple(r['white_noise_per_sample'])} {u} per sample), bias instability "
              f"{_triple(r['bias_instability'])} {u}, random walk {_triple(r['random_walk'])} {u}/√s")
    return 0


def _triple(v) -> str:
    return "[" + ", ".join("-" if not np.isfinite(x) else f"{x:.3g}" for x in v) + "]"


def cmd_plan(args: argparse.Namespace) -> int:
    if args.method != "wang2019":
        return _plan_accelerometer(args)
    from .scenarios.wang2019 import plan_report

    rep = plan_report(args.seed)
    if args.json:
        print(json.dumps(rep))
        return 0
    print("positions (gravity direction in the body frame):")
    for k, p in enumerate(rep["positions_gravity_body"], 1):
        print(f"  {k:2d}: [{p[0]: .3f} {p[1]: .3f} {p[2]: .3f}]")
    print(f"rotation pairs ({rep['turn_angle_deg']:g}° clockwise then counter-clockwise) about:")
    for k, a in enumerate(rep["rotation_axes_body"], 1):
        print(f"  {k:2d}: [{a[0]: .3f} {a[1]: .3f} {a[2]: .3f}]")
    print(f"{'parameter':<10}{'value':>14}{'sensitivity':>14}{'Fisher info':>14}{'CRLB std':>12}  observable")
    for p in rep["parameters"]:
        print(f"{p['parameter']:<10}{p['value']:>14.4g}{p['sensitivity_rms']:>14.4g}"
              f"{p['fisher_information']:>14.4g}{p['crlb_std']:>12.3g}  {'yes' if p['observable'] else 'NO'}")
    return 0


def _plan_accelerometer(args: argparse.Namespace) -> int:
    from .methods import METHODS
    from .plans import accelerometer_plan

    if args.method not in METHODS:
        raise CliError(f"unknown method {args.method!r}; use one of {', '.join(METHODS)}")
    poses = args.poses or ("six" if args.method in ("six_position", "ferraris") else "nine")
    rep = accelerometer_plan(poses, noise=args.noise_acc)
    if args.json:
        print(json.dumps(rep))
        return 0
    print(f"{rep['poses']} static poses (up direction in the body frame), for the linear accelerometer "
          f"model of {args.method}:")
    for k, d in enumerate(rep["directions"], 1):
        print(f"  {k:2d}: [{d[0]: .3f} {d[1]: .3f} {d[2]: .3f}]")
    print(f"Cramér–Rao bound with {rep['noise']:g} m/s^2 of noise on each pose's mean "
          "(scales relative, misalignments in rad, biases in m/s^2):")
    for p in rep["parameters"]:
        bound = f"{p['crlb_std']:.3g}" if p["observable"] else "-"
        verdict = "observable" if p["observable"] else "NOT determined by these poses"
        print(f"  {p['parameter']:<34}{bound:>12}  {verdict}")
    return 0


# ---------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="imucalib",
        description="Calibrate the accelerometer and gyroscope of low-cost MEMS IMUs.",
    )
    parser.add_argument("--version", action="version", version=f"imucalib {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("calibrate", help="estimate a calibration from a recording",
                       description="Estimate biases, scale factors and misalignments from a "
                       "recording of static poses and rotations between them.")
    p.add_argument("data", nargs="+", help="data file(s): one CSV/MAT file, two imu_tk files "
                   "(accelerometer then gyroscope), a ROS bag, or a simulated session directory")
    p.add_argument("--method", default="tedaldi2014", help="calibration method (default: tedaldi2014)")
    p.add_argument("--model", help="model variant, e.g. linear, quadratic, cubic, all")
    p.add_argument("--gravity", type=_positive_float, default=STANDARD_GRAVITY,
                   help=f"local gravity [m/s^2] (default: {STANDARD_GRAVITY})")
    p.add_argument("--init-static", type=_positive_float, metavar="SECONDS",
                   help="length of the initial rest (default: found automatically)")
    p.add_argument("--detector", choices=("accelerometer", "gyroscope"),
                   help="zhang2021: static detector, Tedaldi's accelerometer variance (default) or "
                   "the gyroscope norm of Zhang 2021 eq. (22)")
    p.add_argument("-o", "--output", help="write the calibration file (JSON) here")
    p.add_argument("--plot", metavar="FILE.png", help="write a figure of the fit (needs matplotlib)")
    p.add_argument("--report", metavar="FILE.html",
                   help="write a self-contained HTML report: fit, parameters with errors, warnings, figure")
    p.add_argument("--json", action="store_true", help="print the calibration as JSON on stdout")
    _add_reader_options(p)
    p.set_defaults(func=cmd_calibrate)

    p = sub.add_parser("apply", help="apply a calibration to a recording",
                       description="Write the recording with calibrated columns added "
                       "(every input row and column is kept). A ROS bag is written as a bag "
                       "with the IMU topic calibrated and everything else copied, unless "
                       "OUTPUT ends in .csv.")
    p.add_argument("calibration", help="calibration file (JSON)")
    p.add_argument("data", help="data file to correct")
    p.add_argument("-o", "--output", required=True, help="output CSV file (or, for a ROS bag, the calibrated bag)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    _add_reader_options(p)
    p.set_defaults(func=cmd_apply)

    p = sub.add_parser("compare", help="run every method the data supports and cross-validate",
                       description="Calibrate with every method the recording supports and "
                       "report leave-one-pose-out cross-validated gravity residuals and "
                       "gyroscope angle errors; methods that cannot run say why.")
    p.add_argument("data", nargs="+", help="data file(s), as for calibrate")
    p.add_argument("--gravity", type=_positive_float, default=STANDARD_GRAVITY,
                   help=f"local gravity [m/s^2] (default: {STANDARD_GRAVITY})")
    p.add_argument("--methods", help="comma-separated methods (default: all)")
    p.add_argument("--folds", type=int, default=12,
                   help="held-out poses, spread evenly (0: every pose; default 12)")
    p.add_argument("--json", action="store_true", help="print the comparison as JSON")
    _add_reader_options(p)
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("validate", help="check a calibration on another recording (no refit)",
                       description="Detect the static poses of a recording made after (or apart from) "
                       "the calibration and report the calibration's gravity-norm residual and "
                       "gyroscope angle errors on them, beside the figures it had when it was made.")
    p.add_argument("calibration", help="calibration file (JSON)")
    p.add_argument("data", nargs="+", help="data file(s) with static poses, as for calibrate")
    p.add_argument("--gravity", type=_positive_float, help="local gravity [m/s^2] (default: the calibration's)")
    p.add_argument("--plot", metavar="FILE", help="also draw the fit figure (PNG/SVG/PDF; plot extra)")
    p.add_argument("--json", action="store_true", help="print the figures as JSON")
    _add_reader_options(p)
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("export", help="write a calibration as C source for the device",
                       description="Print (or write) a C99 header with the calibration's constants and "
                       "a function PREFIX_apply(acc_raw, gyro_raw, acc, gyro) that corrects one sample "
                       "exactly as 'imucalib apply' does.")
    p.add_argument("calibration", help="calibration file (JSON)")
    p.add_argument("-o", "--output", help="header file to write (default: standard output)")
    p.add_argument("--prefix", default="imucalib", help="prefix of the C names (default: imucalib)")
    p.add_argument("--float", action="store_true", help="single precision (default: double)")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("detect-fall", help="find free-fall intervals (Zhang 2021, §IV-C)",
                       description="Mark samples whose weightless loss (Zhang 2021, eq. 19) is "
                       "below a threshold as falling; needs a calibration with a lever arm.")
    p.add_argument("calibration", help="calibration file (JSON) with a lever arm")
    p.add_argument("data", help="data file")
    p.add_argument("--threshold", type=_positive_float, default=2.5,
                   help="loss threshold [m/s^2] (default 2.5)")
    p.add_argument("--json", action="store_true", help="print the intervals as JSON")
    _add_reader_options(p)
    p.set_defaults(func=cmd_detect_fall)

    p = sub.add_parser("simulate", help="write a simulated session with known truth",
                       description="Simulate a calibration session (raw recordings, truth.json, "
                       "session.json with the segments) into a directory.")
    p.add_argument("--scenario", default="zhang2021", choices=("zhang2021", "wang2019"),
                   help="scenario (default: zhang2021)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--noise-acc", type=float, help="accelerometer noise [m/s^2] per sample")
    p.add_argument("--noise-gyro", type=float, help="gyroscope noise [rad/s] per sample")
    p.add_argument("--turntable-error", default="3arcsec", choices=("3arcsec", "3arcmin", "3deg"),
                   help="wang2019: turntable angle error, 1 sigma (default 3arcsec)")
    p.add_argument("--dwell", type=_positive_float, default=300.0,
                   help="wang2019: seconds each position is held (default 300)")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("montecarlo", help="seeded simulate → calibrate → compare runs",
                       description="Run a method on many simulated sessions and summarise the "
                       "parameter errors against the truth.")
    p.add_argument("--scenario", default="zhang2021", choices=("zhang2021", "wang2019", "qureshi2017"),
                   help="scenario (default: zhang2021)")
    p.add_argument("--method", required=True)
    p.add_argument("--model", help="model variant")
    p.add_argument("--runs", type=int, default=20)
    p.add_argument("--workers", type=int, default=1, help="parallel processes")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (run i: seed+i)")
    p.add_argument("--baseline", help="also run this method and report the §IV-B reductions")
    p.add_argument("--turntable-error", default="3arcsec", choices=("3arcsec", "3arcmin", "3deg"),
                   help="wang2019: turntable angle error, 1 sigma (default 3arcsec)")
    p.add_argument("--initial", default="estimate", choices=("estimate", "nominal"),
                   help="wang2019: initial values from eqs. (41)-(42) or nominal (default estimate)")
    p.add_argument("--noise-acc", type=float,
                   help="wang2019: accelerometer white noise [m/s^2] per 100 Hz sample (default 100 ug)")
    p.add_argument("--noise-gyro", type=float,
                   help="wang2019: gyroscope white noise [rad/s] per 100 Hz sample (default 0.01 deg/h)")
    p.add_argument("--dwell", type=_positive_float, default=300.0,
                   help="wang2019: seconds each position is held (default 300)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_montecarlo)

    p = sub.add_parser("demo", help="the main job on a built-in session",
                       description="Simulate the Zhang 2021 session, calibrate it with the linear "
                       "and the full model, and show both against the truth.")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("noise", help="Allan-deviation noise parameters of the initial rest",
                       description="Estimate white noise, bias instability and random walk of both "
                       "sensors from the Allan deviation of the recording's initial rest.")
    p.add_argument("data", nargs="+", help="data file(s), as for calibrate")
    p.add_argument("--whole", action="store_true", help="use the whole recording (it must be at rest)")
    p.add_argument("--plot", metavar="FILE", help="also draw the Allan deviation (PNG/SVG/PDF; plot extra)")
    p.add_argument("--calibration", metavar="CALIBRATION.json",
                   help="apply this calibration first: the noise in m/s^2 and rad/s")
    p.add_argument("--kalibr", metavar="imu.yaml",
                   help="write the IMU noise file of Kalibr/OpenVINS/VINS (needs SI units)")
    p.add_argument("--json", action="store_true")
    _add_reader_options(p)
    p.set_defaults(func=cmd_noise)

    p = sub.add_parser("plan", help="print a method's calibration plan and parameter observability",
                       description="Print the positions and rotations of a method's optimal plan "
                       "and, per parameter, its sensitivity and Fisher information.")
    p.add_argument("--method", required=True,
                   help="wang2019 (turntable plan), or any other method (its accelerometer pose plan)")
    p.add_argument("--seed", type=int, default=0, help="wang2019: seed of the typical truth used")
    p.add_argument("--poses", help="six, nine (Ru 2022 Table 3) or a number of evenly spread poses "
                   "(default: six for six_position/ferraris, else nine)")
    p.add_argument("--noise-acc", type=_positive_float, default=0.002,
                   help="noise of one pose's mean [m/s^2] (default 0.002)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_plan)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("always", ImucalibWarning)
            warnings.showwarning = _show_warning
            return int(args.func(args) or 0)
    except BrokenPipeError:  # output piped into e.g. head: not an error
        sys.stderr.close()
        return 0
    except (ValueError, TypeError, OSError, CliError) as exc:
        print(f"imucalib {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_ERROR
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"imucalib: warning: {message}", file=sys.stderr)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
