"""``imucalib export``: a calibration as a C header, OpenVINS's or Kalibr's IMU yaml, or imu_tk's files."""

from __future__ import annotations

import argparse
import math
import sys
import warnings
from pathlib import Path

from ..io.atomic import atomic_write, refuse_overwriting_inputs
from ._common import CliError, add_force_option, check_verdict, print_json, show_warning

__all__ = ["register"]

#: what each format is, for messages
_WHAT = {"c": "C99 header", "openvins": "OpenVINS imu0 intrinsics (kalibr_imu_chain.yaml)",
         "kalibr": "Kalibr imu0 entry (scale-misalignment)", "imutk": "imu_tk parameter files"}


def _raw_scale(text: str) -> tuple[float, float]:
    parts = text.split(",")
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 2:
        raise argparse.ArgumentTypeError(f"expected two numbers ACC,GYRO (e.g. 0.000598,0.000133); got {text!r}")
    if not all(math.isfinite(v) and v > 0 for v in values):
        raise argparse.ArgumentTypeError(f"expected two positive numbers ACC,GYRO (m/s^2 and rad/s per count); got "
                                         f"{text!r}")
    return values  # type: ignore[return-value]


def _format(args: argparse.Namespace) -> str:
    if args.format:
        return args.format
    suffix = Path(args.output).suffix.lower() if args.output else ".h"
    by_suffix = {".h": "c", ".calib": "imutk"}
    if suffix not in by_suffix:
        raise CliError(f"say which format to write {args.output} in: --format c, openvins, kalibr or imutk "
                       "(only .h and .calib name theirs)")
    return by_suffix[suffix]


def _check_options(args: argparse.Namespace, fmt: str) -> None:
    """Options that do not apply to the chosen format are errors rather than silently ignored."""
    applies = {"--prefix": ("c",), "--float": ("c",), "--noise": ("openvins", "kalibr"),
               "--rostopic": ("openvins", "kalibr"), "--raw-scale": ("openvins", "kalibr"),
               "--openvins-model": ("openvins",)}
    given = {"--prefix": args.prefix != "imucalib", "--float": args.float, "--noise": args.noise is not None,
             "--rostopic": args.rostopic is not None, "--raw-scale": args.raw_scale is not None,
             "--openvins-model": args.openvins_model is not None}
    wrong = [flag for flag, on in given.items() if on and fmt not in applies[flag]]
    if wrong:
        raise CliError(f"{', '.join(wrong)} {'does' if len(wrong) == 1 else 'do'} not apply to --format {fmt}")
    if args.json and not args.output:
        raise CliError("--json needs -o: without it the exported text itself goes to standard output")
    if fmt == "imutk" and not args.output:
        raise CliError("imu_tk's parameters are two files: give -o NAME (NAME_acc.calib, NAME_gyro.calib)")


def cmd_export(args: argparse.Namespace) -> int:
    """``imucalib export``: :mod:`imucalib.export` on stdout or into the file(s) named by ``-o``."""
    from .. import export  # imucalib.export costs 87 ms at start-up
    from ..calibration import Calibration  # imucalib.calibration costs 75 ms at start-up
    from ..recording import ImucalibWarning  # imucalib.recording costs 52 ms at start-up

    refuse_overwriting_inputs([args.output], [args.calibration, args.noise])
    fmt = _format(args)
    _check_options(args, fmt)
    outputs = list(export.imutk_paths(args.output)) if fmt == "imutk" else [args.output] if args.output else []
    refuse_overwriting_inputs(outputs, [args.calibration, args.noise])
    cal = Calibration.load(args.calibration)
    check_verdict(cal, args.calibration, args.force)
    notes: list[str] = []
    if args.temperature is not None:
        if cal.thermal is None:
            raise CliError(f"--temperature applies to a calibration that follows temperature; {args.calibration} "
                           "is for one temperature")
        from ..thermal import at_temperature  # imucalib.thermal costs 58 ms at start-up

        try:
            cal, notes = at_temperature(cal, args.temperature)
        except ValueError as exc:
            raise CliError(f"--temperature {args.temperature}: {exc}") from None
    elif cal.thermal is not None and fmt != "c":
        raise CliError(f"{args.calibration} follows temperature, which --format {fmt} has no place for: pass "
                       "--temperature C to write it at one temperature (the C header follows it)")
    if cal.magnetometer is not None and fmt != "c":
        notes.append(f"the magnetometer calibration has no place in the {_WHAT[fmt]}: it is left out (the JSON "
                     "and the C header hold it)")
    if fmt in ("c", "imutk"):  # their notes (an accelerometer-only calibration's identity gyroscope) are warnings
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ImucalibWarning)
            texts = ([export.to_c(cal, prefix=args.prefix, ctype="float" if args.float else "double")]
                     if fmt == "c" else list(export.to_imutk(cal)))
        for w in caught:
            if issubclass(w.category, ImucalibWarning):
                notes.append(str(w.message))
            else:
                show_warning(w.message, w.category)
    else:
        noise = None
        if args.noise:
            noise, notes = export.read_noise(args.noise)
        convert = export.to_openvins if fmt == "openvins" else export.to_kalibr
        extra = {"model": args.openvins_model or "kalibr"} if fmt == "openvins" else {}
        text, more = convert(cal, raw_scale=args.raw_scale, noise=noise, rostopic=args.rostopic, **extra)
        texts, notes = [text], notes + more
    for n in notes:
        show_warning(n)
    if not outputs:
        sys.stdout.write(texts[0])
        return 0
    if len(outputs) == 2:  # both files replaced at the end of the block, or neither
        with atomic_write(outputs[0], "w", encoding="utf-8") as f0, atomic_write(outputs[1], "w",
                                                                                 encoding="utf-8") as f1:
            f0.write(texts[0])
            f1.write(texts[1])
    else:
        with atomic_write(outputs[0], "w", encoding="utf-8") as fh:
            fh.write(texts[0])
    if args.json:
        return print_json({"calibration": str(args.calibration), "format": fmt, "outputs": outputs,
                           "notes": notes})
    temp = ", temperature_c" if cal.thermal is not None else ""
    what = f"{args.prefix}_apply(acc_raw, gyro_raw{temp}, acc, gyro)" if fmt == "c" else _WHAT[fmt]
    if fmt == "c" and cal.magnetometer is not None:
        what += f" and {args.prefix}_apply_mag(mag_raw, mag)"
    print(f"wrote {' and '.join(outputs)}: {what}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add export to the ``imucalib`` sub-commands."""
    p = sub.add_parser("export", help="write a calibration for a device or another tool",
                       description="Write the calibration as a C99 header with PREFIX_apply(acc_raw, gyro_raw, "
                       "acc, gyro) correcting one sample exactly as 'imucalib apply' does (--format c, the "
                       "default, and for a .h file), as the imu0 intrinsics of OpenVINS's kalibr_imu_chain.yaml "
                       "(openvins), as Kalibr's imu0 entry with its scale-misalignment intrinsics (kalibr), or as "
                       "imu_tk's two parameter files (imutk). All but the header hold a linear model only; a "
                       "calibration they cannot hold is refused with the reason. OpenVINS and Kalibr read m/s^2 "
                       "and rad/s and estimate the biases online (the file names them in a comment); a "
                       "calibration of raw counts needs --raw-scale. A rejected calibration is refused unless "
                       "--force is given.")
    p.add_argument("calibration", help="calibration file (JSON)")
    p.add_argument("-o", "--output", help="file to write (default: standard output); for imutk the NAME of "
                   "NAME_acc.calib and NAME_gyro.calib")
    p.add_argument("--format", choices=("c", "openvins", "kalibr", "imutk"),
                   help="c (default; .h), openvins, kalibr or imutk (.calib)")
    p.add_argument("--prefix", default="imucalib", help="c: prefix of the C names (default: imucalib)")
    p.add_argument("--float", action="store_true", help="c: single precision (default: double)")
    p.add_argument("--noise", metavar="FILE", help="openvins, kalibr: the noise entries (and rostopic, "
                   "update_rate) from Kalibr's imu.yaml or the JSON of 'imucalib noise --json' in SI units")
    p.add_argument("--rostopic", metavar="TOPIC", help="openvins, kalibr: the IMU topic (default: the --noise "
                   "file's)")
    p.add_argument("--raw-scale", type=_raw_scale, metavar="ACC,GYRO",
                   help="openvins, kalibr, for a calibration of raw counts: m/s^2 and rad/s per count as the "
                   "driver publishes them (1,1: it publishes the counts themselves)")
    p.add_argument("--temperature", type=float, metavar="C", help="for a calibration that follows temperature: "
                   "write it as it is at C degrees (the formats other than c have no place for the thermal model)")
    p.add_argument("--openvins-model", choices=("kalibr", "rpng"),
                   help="openvins: the IMU model, kalibr (default: lower-triangular Dw, Da) or rpng (upper)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout (with -o)")
    add_force_option(p)
    p.set_defaults(func=cmd_export)
