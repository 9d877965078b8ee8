"""Commands on simulated sessions with known truth: simulate, montecarlo, demo, reproduce."""

from __future__ import annotations

import argparse
import math
import sys

from ._common import CliError, Progress, add_method_option, positive_float, print_json, progress
from .fleet import add_scheduler_option

__all__ = ["register", "scenario_choices"]

#: the names of :data:`imucalib.scenarios.SCENARIOS`, written out so that building the parser imports no simulator
#: (a test checks that the two agree)
SCENARIOS = ("zhang2021", "handheld")
#: scenarios with a simulator of their own outside :data:`imucalib.scenarios.SCENARIOS` (turntable aggregates)
TURNTABLE_SCENARIOS = ("wang2019",)
#: scenarios whose Monte Carlo is a paper's own experiment (:func:`imucalib.experiments.qureshi2017.montecarlo`)
EXPERIMENT_SCENARIOS = ("qureshi2017",)


def scenario_choices(*special: str) -> tuple[str, ...]:
    """The scenario names of :data:`imucalib.scenarios.SCENARIOS`, then ``special`` ones not among them.

    The simulators are not imported for this: when a program has loaded them, their registry is read
    (scenarios it added included), else the built-in names of :data:`SCENARIOS`.
    """
    loaded = sys.modules.get(__name__.rsplit(".", 2)[0] + ".scenarios")
    names = tuple(loaded.SCENARIOS) if loaded is not None else SCENARIOS
    return (*names, *(s for s in special if s not in names))


def _noise_options(args: argparse.Namespace) -> dict | None:
    """``--noise-acc``/``--noise-gyro`` as a scenario's noise overrides (per sample, SI units)."""
    noise = {k: v for k, v in (("accelerometer", args.noise_acc), ("gyroscope", args.noise_gyro)) if v is not None}
    return noise or None


def _ramp(text: str) -> tuple[float, float, float]:
    try:
        start, end, tau = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected START,END,TAU (°C, °C, seconds), e.g. 22,40,150; got {text!r}") \
            from None
    return start, end, tau


def _handheld_options(args: argparse.Namespace) -> dict:
    """The hand-held scenario's magnetometer and temperature options; an error for another scenario."""
    out = {k: v for k, v in (("magnetometer", args.magnetometer or None), ("temperature", args.temperature),
                             ("ramp", args.ramp)) if v is not None}
    if out and args.scenario != "handheld":
        raise CliError(f"--magnetometer, --temperature and --ramp apply to --scenario handheld, not {args.scenario}")
    return out


# ------------------------------------------------------------------ commands
def cmd_simulate(args: argparse.Namespace) -> int:
    """``imucalib simulate``: a scenario's session written by :func:`imucalib.scenarios.write_session`."""
    from ..scenarios import session, write_session  # imucalib.scenarios costs 145 ms at start-up

    if args.scenario == "wang2019":
        from ..scenarios.wang2019 import session as wang_session  # imucalib.scenarios.wang2019 costs 166 ms at start-up

        sim = wang_session(args.seed, turntable_error=args.turntable_error, noise=_noise_options(args),
                           dwell_s=args.dwell)
        out = write_session(sim, args.output, overwrite=args.force)
        summary = {"scenario": "wang2019", "seed": args.seed, "directory": str(out),
                   "positions": len(sim.positions_acc), "turn_pairs": len(sim.turn_sum)}
        if args.json:
            return print_json(summary)
        print(f"wrote the wang2019 session (seed {args.seed}) to {out}: {summary['positions']} "
              f"positions, {summary['turn_pairs']} turn pairs")
        return 0
    sim = session(args.scenario, rng=args.seed, noise=_noise_options(args), **_handheld_options(args))
    out = write_session(sim, args.output, overwrite=args.force)
    summary = {"scenario": args.scenario, "seed": args.seed, "directory": str(out),
               "samples": len(sim.recording), "static": sum(s.kind == "static" for s in sim.segments),
               "weightless": len(sim.weightless), "tests": len(sim.tests), "noise": sim.noise}
    if args.json:
        return print_json(summary)
    print(f"wrote the {args.scenario} session (seed {args.seed}) to {out}: "
          f"{summary['samples']} RD1 samples, {summary['static']} static poses, "
          f"{summary['weightless']} weightless spins, {summary['tests']} test tosses")
    return 0


def cmd_montecarlo(args: argparse.Namespace) -> int:
    """``imucalib montecarlo``: :func:`imucalib.experiments.evaluate.montecarlo`, or a paper's own experiment."""
    from ..experiments.evaluate import montecarlo  # imucalib.experiments.evaluate costs 280 ms at start-up

    if args.scheduler is not None and args.scenario in (*TURNTABLE_SCENARIOS, *EXPERIMENT_SCENARIOS):
        raise CliError(f"--scheduler runs the simulate → calibrate Monte Carlo of {', '.join(SCENARIOS)}; the "
                       f"{args.scenario} experiment runs on local processes (--workers)")
    workers = args.workers or 1
    if args.scenario == "wang2019":
        if args.method != "wang2019":
            raise CliError("the wang2019 scenario holds turntable data: use --method wang2019")
        # imucalib.experiments.wang2019 costs 276 ms at start-up
        from ..experiments.wang2019 import montecarlo as wang_mc

        result = wang_mc(args.runs, turntable_error=args.turntable_error, seed=args.seed,
                         initial=args.initial, workers=workers, noise=_noise_options(args),
                         dwell_s=args.dwell)
        return print_json(result) if args.json else _print_wang_montecarlo(result)
    if args.scenario == "qureshi2017":
        if args.method != "qureshi2017":
            raise CliError("the qureshi2017 scenario reproduces Qureshi 2017 §IV: use --method qureshi2017")
        # imucalib.experiments.qureshi2017 costs 297 ms at start-up
        from ..experiments.qureshi2017 import montecarlo as qureshi_mc

        result = qureshi_mc(args.runs, seed=args.seed, workers=workers)
        return print_json(result) if args.json else _print_qureshi_montecarlo(result)
    if _noise_options(args) is not None:
        raise CliError("--noise-acc/--noise-gyro apply to the wang2019 scenario here; for the others "
                       "write a session with `imucalib simulate --noise-…` and calibrate it")
    result = montecarlo(args.scenario, args.method, model=args.model, runs=args.runs,
                        workers=workers if args.scheduler is None else args.workers,
                        scheduler=args.scheduler, seed=args.seed, baseline=args.baseline,
                        progress=Progress(f"montecarlo {args.method} on {args.scenario}", unit="run"))
    if args.json:
        return print_json(result)
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
    print("verdicts: " + ", ".join(f"{n} {level}" for level, n in result["verdicts"].items())
          + f" (of the {result['runs'] - len(result['failures'])} runs that produced a calibration)")
    for f in result["failures"]:
        print(f"seed {f['seed']}: {f['message']}")
    return 0


def _print_wang_montecarlo(result: dict) -> int:
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
    return 0


def _print_qureshi_montecarlo(result: dict) -> int:
    """The Qureshi 2017 §IV figures beside the paper's."""
    print(f"{result['runs']} runs of qureshi2017 (18 orientations, 2 s each at 100 Hz, Table II-like truth)")
    print(f"  RMS(|a| - g) over 92 fresh orientations: raw {result['raw_rms_g_mean']:.4g} g, calibrated "
          f"{result['calibrated_rms_g_mean']:.3g} g; reduction {result['reduction_fold_min']:.0f}-fold at least "
          "(paper: 0.0129 g -> 0.0014 g)")
    g = result["gyro_scale_rel_error_max"]
    print(f"  gyroscope scales, worst relative error: static-bias {g['static']:.2%}, dynamic {g['dynamic']:.2%} "
          "(paper: within 0.41 %)")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """``imucalib demo``: :func:`imucalib.experiments.demo.run_demo`, told as a short story."""
    from ..experiments.demo import run_demo  # imucalib.experiments.demo costs 117 ms at start-up

    r = run_demo(args.output, args.seed, overwrite=args.force,
                 progress=progress(not args.json and sys.stderr.isatty()))
    if args.json:
        return print_json(r.to_dict())
    b, a, t = r.before, r.after, r.truth
    floor = f" (noise floor {r.noise_floor:.2g})" if r.noise_floor is not None else ""
    rms = f"; |a| - g over them {r.residual_rms:.2g} m/s^2{floor}" if r.residual_rms is not None else ""
    print("imucalib demo: a simulated IMU calibrated, then checked against the truth it was simulated from\n")
    print(f"sensor     an MPU-6050-like IMU in raw counts (seed {r.seed}): biases, scale errors of a few %, axes "
          "a little askew, noise")
    print(f"recorded   {r.duration_s:.0f} s at {r.rate_hz:.0f} Hz, held by hand: a rest, then poses of a few "
          f"seconds with turns between them -> {r.folder / 'session'}")
    print(f"calibrated {r.method} (the default method) found {r.poses} poses{rms}")
    print(f"verdict    {r.verdict.upper()}" + (f": {r.reasons[0]}" if r.reasons else " (the checks are in the report)"))
    print("\nerrors against the true sensor      datasheet factors   calibrated   true parameters")
    print(f"  accelerometer, worst pose [mg]     {b.accelerometer_mg:>16.3g}{a.accelerometer_mg:>13.3g}"
          f"{t.accelerometer_mg:>18.3g}")
    print(f"  gyroscope at rest, worst [deg/s]   {b.gyroscope_dps:>16.3g}{a.gyroscope_dps:>13.3g}"
          f"{t.gyroscope_dps:>18.3g}")
    if b.angle_deg is not None and a.angle_deg is not None and t.angle_deg is not None:
        print(f"  gravity after a turn, mean [deg]   {b.angle_deg:>16.3g}{a.angle_deg:>13.3g}{t.angle_deg:>18.3g}")
    print("  (datasheet factors: 16384 counts/g and 131 counts/(deg/s), no bias; the last row is the gyroscope's\n"
          "   integrated attitude against gravity at the next pose, where noise alone leaves the true parameters'"
          " error)")
    print("\nwrote      " + "  ".join(str(f) for f in r.files))
    print("\nthe same on your own recording (a rest, then a dozen poses held 2-4 s; `imucalib plan` says which):")
    print("  imucalib calibrate my_session.csv -o calib.json --report report.html")
    print("  imucalib apply calib.json my_session.csv -o my_session_calibrated.csv")
    print("  imucalib validate calib.json another_session.csv")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    """``imucalib reproduce zhang2021``: :func:`imucalib.experiments.zhang2021.demo`, beside the paper's figures."""
    from ..experiments.zhang2021 import demo  # imucalib.experiments.zhang2021 costs 263 ms at start-up

    result = demo(args.seed, progress=progress(not args.json and sys.stderr.isatty()))
    if args.json:
        return print_json(result)
    print("Zhang 2021 §IV on its simulated session (Table I truth, seed "
          f"{args.seed}): tedaldi2014, zhang2021 'linear' and zhang2021 'all' (3rd-order scale factors, lever arm)")
    print(f"{'parameter':<36}{'truth':>14}{'linear':>14}{'all':>14}{'all ± 1σ':>11}{'error/σ':>9}")
    within = []
    for r in result["parameters"]:
        lv = "-" if r["linear"] is None else f"{r['linear']:.6g}"
        sd = r["all_std"]
        if sd is not None and math.isfinite(sd) and sd > 0:
            z = (r["all"] - r["truth"]) / sd
            within.append(abs(z) <= 2)
            tail = f"{sd:>11.2g}{z:>9.2f}"
        else:
            tail = f"{'-':>11}{'-':>9}"
        print(f"{r['name']:<36}{r['truth']:>14.6g}{lv:>14}{r['all']:>14.6g}{tail}")
    print("linear: the linear model's estimate (- where it has no such parameter); all: the full model's, with its "
          "1σ and (all - truth)/1σ")
    if within:
        print(f"the full model's 1σ errors: {sum(within)} of {len(within)} estimates within 2σ of the truth "
              "(about 95 % expected)")
    print("\nverdicts: the sensor's scale factors are nonlinear, so the linear models leave structure")
    for name, v in result["verdicts"].items():
        first = f": {v['reasons'][0]}" if v["reasons"] else ""
        print(f"  {name:<12} {str(v['verdict']).upper()}{first}")
    mt = result["metrics"]
    print("\non the session's test tosses (Zhang 2021 §IV-B), mean over the tosses:  tedaldi2014      linear"
          "         all")
    print(f"  eq. (34) accelerometer error over the weightless spin [(m/s^2)^2] {mt['eq34_mean']['tedaldi2014']:>11.4g}"
          f"{mt['eq34_mean']['linear']:>12.4g}{mt['eq34_mean']['all']:>12.4g}")
    eq35 = mt["eq35_mean"]
    print(f"  eq. (35) cosine of gravity carried through the toss by the gyroscope {eq35['tedaldi2014']:>8.6f}"
          f"{mt['eq35_mean']['linear']:>12.6f}{mt['eq35_mean']['all']:>12.6f}")
    print(f"  reduction of 'all' against tedaldi2014: eq. (34) {mt['all_vs_tedaldi2014_eq34_reduction']:.2%}, "
          f"eq. (35) {mt['all_vs_tedaldi2014_eq35_reduction']:.2%} (paper: 64.12 %, 47.90 %)")
    print("the reductions differ from the paper's because the sensor differs: the simulated one follows the full "
          "model exactly\n(Table I's parameters, white noise), so the full model's fit leaves only noise and removes "
          "nearly all the error;\nthe tosses spin fast, where the cubic scale factors the linear models lack "
          "dominate; the paper's real sensor has\nerrors the full model describes only in part")
    print(f"done in {result['seconds']:.1f} s")
    return 0


# -------------------------------------------------------------------- parsers
def _add_wang_options(p: argparse.ArgumentParser) -> None:
    """``--turntable-error`` of the wang2019 scenario."""
    p.add_argument("--turntable-error", default="3arcsec", choices=("3arcsec", "3arcmin", "3deg"),
                   help="wang2019: turntable angle error, 1 sigma (default 3arcsec)")


def _add_dwell_option(p: argparse.ArgumentParser) -> None:
    p.add_argument("--dwell", type=positive_float, default=300.0,
                   help="wang2019: seconds each position is held (default 300)")


def register(sub: argparse._SubParsersAction) -> None:
    """Add simulate, montecarlo, demo and reproduce to the ``imucalib`` sub-commands."""
    p = sub.add_parser("simulate", help="write a simulated session with known truth",
                       description="Simulate a calibration session (raw recordings, truth.json, "
                       "session.json with the segments) into a directory.")
    p.add_argument("--scenario", default="zhang2021", choices=scenario_choices(*TURNTABLE_SCENARIOS),
                   help="scenario (default: zhang2021)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--noise-acc", type=float, help="accelerometer noise [m/s^2] per sample")
    p.add_argument("--noise-gyro", type=float, help="gyroscope noise [rad/s] per sample")
    _add_wang_options(p)
    _add_dwell_option(p)
    p.add_argument("--magnetometer", action="store_true",
                   help="handheld: add a magnetometer (MPU-9250-like: axes swapped and z reversed, hard and soft iron)")
    p.add_argument("--temperature", type=float, metavar="C", help="handheld: the sensor at C degrees (datasheet-like "
                   "thermal coefficients around 25 °C; a temperature column)")
    p.add_argument("--ramp", type=_ramp, metavar="START,END,TAU", help="handheld: a warm-up from START to END °C "
                   "with time constant TAU seconds instead")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--force", action="store_true", help="overwrite the session's files in an existing folder (by "
                   "default a folder holding any of them is refused)")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("montecarlo", help="seeded simulate → calibrate → compare runs",
                       description="Run a method on many simulated sessions and summarise the "
                       "parameter errors against the truth.")
    p.add_argument("--scenario", default="zhang2021",
                   choices=scenario_choices(*TURNTABLE_SCENARIOS, *EXPERIMENT_SCENARIOS),
                   help="scenario (default: zhang2021)")
    add_method_option(p, required=True)
    p.add_argument("--model", help="model variant")
    p.add_argument("--runs", type=int, default=20)
    p.add_argument("--workers", type=int, help="parallel processes (default 1); with --scheduler local, the "
                   "LocalCluster's workers (default one per core)")
    add_scheduler_option(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (run i: seed+i)")
    p.add_argument("--baseline", help="also run this method and report the §IV-B reductions")
    _add_wang_options(p)
    p.add_argument("--initial", default="estimate", choices=("estimate", "nominal"),
                   help="wang2019: initial values from eqs. (41)-(42) or nominal (default estimate)")
    p.add_argument("--noise-acc", type=float,
                   help="wang2019: accelerometer white noise [m/s^2] per 100 Hz sample (default 100 ug)")
    p.add_argument("--noise-gyro", type=float,
                   help="wang2019: gyroscope white noise [rad/s] per 100 Hz sample (default 0.01 deg/h)")
    _add_dwell_option(p)
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_montecarlo)

    p = sub.add_parser("demo", help="calibrate a simulated IMU and check it against its truth",
                       description="Simulate a hand-held session of an MPU-6050-like IMU (raw counts), calibrate "
                       "it with the default method, apply the calibration, and compare the readings before and "
                       "after with the true sensor. Writes FOLDER/session/ (the recording and its truth), "
                       "FOLDER/calib.json, FOLDER/calibrated.csv and FOLDER/report.html (-o, default imucalib-demo).")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated sensor and session (default 0)")
    p.add_argument("-o", "--output", default="imucalib-demo", metavar="FOLDER",
                   help="folder for the session, calib.json, calibrated.csv and report.html (default: "
                   "imucalib-demo, created if missing)")
    p.add_argument("--force", action="store_true", help="replace those files when the folder holds them already")
    p.add_argument("--json", action="store_true", help="print the result as JSON (the figures and the files)")
    p.set_defaults(func=cmd_demo)

    p = sub.add_parser("reproduce", help="a paper's experiment on its simulated session, beside its figures",
                       description="Reproduce a paper's experiment on simulation. zhang2021: Zhang et al. 2021 "
                       "§IV on a session with Table I's truth: the linear and the full model against the truth, "
                       "their verdicts, and the eq. (34)-(35) errors on the test tosses with the reductions the "
                       "paper reports.")
    p.add_argument("paper", choices=("zhang2021",), help="the paper (zhang2021)")
    p.add_argument("--seed", type=int, default=0, help="seed of the simulated session (default 0)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=cmd_reproduce)
