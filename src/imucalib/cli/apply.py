"""``imucalib apply``: a calibration applied to a recording, read as ``calibrate`` reads it.

Every input ``calibrate`` takes is taken here: one CSV/MAT file, imu_tk's two
files, a phone app's accelerometer and gyroscope files, a ROS bag (written
back as a bag unless the output ends in ``.csv``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..io.atomic import refuse_overwriting_inputs
from ._common import (
    CliError,
    add_force_option,
    add_poses_option,
    add_reader_options,
    check_verdict,
    print_json,
    read_recording,
    reading_progress,
    show_warning,
)

__all__ = ["cmd_apply", "register"]


def _is_bag(args: argparse.Namespace) -> bool:
    from ..io.rosbag import is_rosbag  # imucalib.io.rosbag costs 56 ms at start-up

    return args.reader == "rosbag" or (args.reader is None and len(args.data) == 1 and is_rosbag(Path(args.data[0])))


def cmd_apply(args: argparse.Namespace) -> int:
    """``imucalib apply``: :meth:`Calibration.apply` into a CSV, or a ROS bag calibrated topic by topic."""
    from ..calibration import Calibration  # imucalib.calibration costs 79 ms at start-up
    from ..io import write_csv  # imucalib.io costs 99 ms at start-up

    refuse_overwriting_inputs([args.output], [args.calibration, *args.data])
    cal = Calibration.load(args.calibration)
    check_verdict(cal, args.calibration, args.force)
    verdict = cal.fit.verdict.level
    if args.poses:
        return _apply_table(args, cal, verdict)
    if _is_bag(args) and Path(args.output).suffix.lower() != ".csv":
        from ..io.rosbag import write_calibrated_bag  # imucalib.io.rosbag costs 56 ms at start-up

        if len(args.data) != 1:
            raise CliError(f"a ROS bag is one input; got {len(args.data)}: {', '.join(args.data)}")
        if args.bias_drift == "on" and cal.bias_drift is not None:
            raise CliError("a ROS bag is calibrated message by message with the constant gyroscope bias: "
                           "--bias-drift on needs a CSV output (-o FILE.csv)")
        if args.bias_drift == "auto" and cal.bias_drift is not None:
            show_warning("the calibration's gyroscope bias drifts (its fit found it): a ROS bag is calibrated with "
                         "the constant bias stored; for the drifting bias on the calibrated session write a CSV "
                         "(-o FILE.csv)")
        with reading_progress(args, f"calibrating {args.data[0]}") as bar:
            summary = write_calibrated_bag(args.data[0], args.output, cal, topic=args.topic, progress=bar)
        summary["calibration"] = str(args.calibration)
        summary["verdict"] = verdict
        if args.json:
            return print_json(summary)
        print(f"wrote {args.output}: {summary['corrected']} {summary['topic']} messages calibrated, "
              f"{summary['copied']} other messages copied unchanged")
        return 0
    rec = read_recording(args, args.data)
    out = cal.apply(rec, bias_drift=args.bias_drift)
    if cal.gyroscope is None and rec.gyro is not None:
        show_warning("the calibration has no gyroscope (its recording had none, or no rotations between poses): "
                     "the gyroscope columns are copied uncalibrated")
    mag = None
    if cal.magnetometer is not None and rec.mag is not None:
        mag = out.mag
    elif cal.magnetometer is not None or rec.mag is not None:
        show_warning("the calibration has a magnetometer but the data have no magnetometer columns"
                     if rec.mag is None else "the data have magnetometer columns but the calibration has no "
                     "magnetometer: they are copied uncalibrated")
    write_csv(args.output, rec, calibrated_acc=out.acc, calibrated_gyro=out.gyro, calibrated_mag=mag,
              mag_unit=out.mag_unit)
    source = args.data[0] if len(args.data) == 1 else list(args.data)
    if args.json:
        return print_json({"input": source, "output": str(args.output), "samples": len(rec),
                           "calibration": str(args.calibration), "method": cal.method, "verdict": verdict,
                           "gyroscope_bias_drift": out.metadata["gyroscope_bias_drift"] if out.gyro is not None
                           else None})
    drift = " (gyroscope bias drifting as fitted)" if out.metadata["gyroscope_bias_drift"] == "applied" else ""
    print(f"wrote {len(rec)} calibrated samples to {args.output}{drift}")
    return 0


def _apply_table(args: argparse.Namespace, cal, verdict) -> int:
    """``imucalib apply --poses``: the table of averaged poses written again with its calibrated columns."""
    from ..io.posetable import read_pose_table, write_pose_table  # imucalib.io.posetable costs 58 ms at start-up
    from ..methods import apply_to_table  # imucalib.methods costs 186 ms at start-up

    if len(args.data) != 1:
        raise CliError(f"a table of averaged poses is one file; got {len(args.data)}: {', '.join(args.data)}")
    table = read_pose_table(args.data[0], acc_unit=args.acc_unit, gyro_unit=args.gyro_unit,
                            fallback_acc_unit=cal.units["accelerometer"]["raw"],
                            fallback_gyro_unit=(cal.units.get("gyroscope") or {}).get("raw"))
    out = apply_to_table(cal, table)
    for note in out.notes:
        show_warning(note)
    write_pose_table(args.output, table, out.acc, out.gyro)
    if args.json:
        return print_json({"input": args.data[0], "output": str(args.output), "poses": len(table),
                           "calibration": str(args.calibration), "method": cal.method, "verdict": verdict})
    print(f"wrote {len(table)} calibrated poses to {args.output}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``apply`` to the ``imucalib`` sub-commands."""
    p = sub.add_parser("apply", help="apply a calibration to a recording",
                       description="Write the recording with calibrated columns added "
                       "(every input row and column is kept). The data are read as 'calibrate' reads them: "
                       "one CSV/MAT file, two imu_tk files (accelerometer, then gyroscope), a phone app's "
                       "accelerometer and gyroscope files, or a ROS bag. A ROS bag is written as a bag "
                       "with the IMU topic calibrated and everything else copied, unless "
                       "OUTPUT ends in .csv. A rejected calibration is refused unless --force is given.")
    p.add_argument("calibration", help="calibration file (JSON)")
    p.add_argument("data", nargs="+", help="data file(s) to correct, as for calibrate")
    p.add_argument("-o", "--output", required=True, help="output CSV file (or, for a ROS bag, the calibrated bag)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.add_argument("--bias-drift", choices=("auto", "on", "off"), default="auto",
                   help="correct the gyroscope bias with the drift the calibration found, b + d (t - t_ref): "
                   "auto (default) on the recording the calibration was made from (or a part of it), the "
                   "constant bias on any other; on: always, in the data's time base; off: never")
    add_force_option(p)
    add_poses_option(p, "it is written again with the calibrated means appended to each row")
    add_reader_options(p)
    p.set_defaults(func=cmd_apply)
