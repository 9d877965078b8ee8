"""Check a calibration on another recording: validate.

:func:`imucalib.validation.validate` finds the poses without fitting anything and
judges the calibration on them; the command prints the verdict first, then
the figures beside those at calibration, and exits with
:data:`._common.EXIT_REJECTED` when the calibration no longer holds.
"""

from __future__ import annotations

import argparse

from ..io.atomic import refuse_overwriting_inputs
from ._common import (
    EXIT_REJECTED,
    add_init_static_option,
    add_min_hold_option,
    add_reader_options,
    gravity_value,
    load_calibration,
    print_json,
    print_verdict,
    read_recording,
)

__all__ = ["HEADLINES", "register"]

#: the first line of the text output, by verdict
HEADLINES = {"accepted": "verdict: ACCEPTED — the calibration holds on this recording",
             "suspect": "verdict: SUSPECT — the calibration may not hold on this recording (reasons below)",
             "rejected": "verdict: REJECTED — the calibration does not hold on this recording"}


def cmd_validate(args: argparse.Namespace) -> int:
    """``imucalib validate``: :func:`imucalib.validation.validate`, the verdict first, then the figures."""
    from ..calibration import Calibration  # imucalib.calibration costs 127 ms at start-up
    from ..fitreport import VerdictReport  # 14 ms, kept off --version's start-up (no slower than it was)
    from ..recording import Interval  # imucalib.recording costs 75 ms at start-up
    from ..validation import validate  # imucalib.validation costs 130 ms at start-up

    refuse_overwriting_inputs([args.plot], [args.calibration, *args.data])
    if args.calibration.endswith(".calib"):  # imu_tk's pair: read against the recording's units
        rec = read_recording(args, args.data)
        cal = load_calibration(args.calibration, rec, args.gravity)
    else:  # checked before the recording is read
        cal = Calibration.load(args.calibration)
        rec = read_recording(args, args.data)
    result = {"calibration": str(args.calibration),
              **validate(cal, rec, args.gravity, init_static=args.init_static,
                       **({} if args.min_hold is None else {"min_hold": args.min_hold}))}
    intervals = [Interval(a, b) for a, b in result.pop("intervals")]
    if args.plot:
        from ..report import plot_fit  # imucalib.report costs 98 ms at start-up

        plot_fit(cal, rec, intervals, args.plot)
    code = EXIT_REJECTED if result["verdict"] == "rejected" else 0
    if args.json:
        print_json(result)
        return code
    print_verdict(VerdictReport(level=result["verdict"], reasons=result["verdict_reasons"],
                                notes=result["verdict_notes"]), HEADLINES[result["verdict"]])
    if result["own_recording"]:
        print("note: this is the recording the calibration was made from (or a part of it), so these are its own "
              "figures again; validate it on a recording it was not made from")
    then = result["at_calibration"]
    print(f"{cal.method} calibration on {len(intervals)} static poses of this recording (not refitted):")
    if result["temperature_c"] and cal.thermal is not None:
        lo, hi = cal.thermal.range_c
        t_now = result["temperature_c"][1]
        print(f"  temperature {t_now:.1f} °C (the calibration follows temperature, made over {lo:.1f}–{hi:.1f} °C)"
              + ("  — outside that range: it extrapolates" if not lo - 1 <= t_now <= hi + 1 else ""))
    elif result["temperature_c"] and then["temperature_c"]:
        t_now, t_then = result["temperature_c"][1], then["temperature_c"][1]
        print(f"  temperature {t_now:.1f} °C (at calibration {t_then:.1f} °C)"
              + ("  — more than 5 °C apart: biases may have drifted" if abs(t_now - t_then) > 5 else ""))
    for k, label, unit in (("accelerometer_residual_rms", "‖a‖ − g RMS", "m/s^2"),
                           ("accelerometer_residual_to_noise", "… / its noise floor", "×"),
                           ("gyroscope_angle_error_mean_deg", "gyro angle error mean", "deg"),
                           ("gyroscope_angle_error_max_deg", "gyro angle error max", "deg"),
                           ("gyroscope_angle_error_predicted_deg", "… noise alone predicts", "deg")):
        now = result[k]
        if now is None:
            continue
        ref = f"   (at calibration {then[k]:.4g}: ×{now / then[k]:.2f})" if then.get(k) else ""
        if k == "gyroscope_angle_error_predicted_deg" and result["gyroscope_error_to_noise"] is not None:
            ref = f"   (the error is {result['gyroscope_error_to_noise']:.3g}× it)"
        if result.get(f"{k}_raw") is not None:  # the raw readings (the identity calibration) on the same data
            ref += f"   (raw readings {result[k + '_raw']:.4g})"
        print(f"  {label:<24}{now:10.4g} {unit}{ref}")
    if args.plot:
        print(f"plot written to {args.plot}")
    return code


def register(sub: argparse._SubParsersAction) -> None:
    """Add validate to the ``imucalib`` sub-commands."""
    p = sub.add_parser("validate", help="check a calibration on another recording (no refit)",
                       description="Find the static poses of a recording made after (or apart from) the "
                       "calibration - the initial rest and every pose held still for a second, found "
                       "without fitting anything, so a rest and one turn are enough - and judge the "
                       "calibration on them: the gravity-norm residual against the noise floor and the "
                       "gyroscope's angle errors against what its noise predicts, beside the figures it had "
                       "when it was made. The verdict comes first; exit code 3 when it no longer holds.")
    p.add_argument("calibration", help="calibration file (JSON), or imu_tk's NAME_acc.calib (with NAME_gyro.calib "
                   "beside it: imu_tk's calibration checked in the same way; pass --gravity as given to imu_tk)")
    p.add_argument("data", nargs="+", help="data file(s), as for calibrate")
    p.add_argument("--gravity", type=gravity_value, help="local gravity [m/s^2] (default: the calibration's)")
    add_init_static_option(p)
    add_min_hold_option(p)
    p.add_argument("--plot", metavar="FILE", help="also draw the fit figure (PNG/SVG/PDF; plot extra)")
    p.add_argument("--json", action="store_true", help="print the verdict and the figures as JSON")
    add_reader_options(p)
    p.set_defaults(func=cmd_validate)
