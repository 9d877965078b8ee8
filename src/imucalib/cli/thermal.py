"""``imucalib thermal``: calibrations made at several temperatures combined into one that follows temperature."""

from __future__ import annotations

import argparse

from ..io.atomic import refuse_overwriting_inputs
from ._common import CliError, print_json

__all__ = ["register"]


def cmd_thermal(args: argparse.Namespace) -> int:
    """:func:`imucalib.thermal.combine` over the files, the decisions printed, the result written."""
    from ..calibration import Calibration  # imucalib.calibration costs 115 ms at start-up
    from ..thermal import combine  # imucalib.thermal costs 91 ms at start-up

    refuse_overwriting_inputs([args.output, args.plot], args.calibrations)
    cals = []
    for path in args.calibrations:
        try:
            cals.append(Calibration.load(path))
        except ValueError as exc:
            raise CliError(str(exc)) from None
    try:
        out, decisions = combine(cals, reference_c=args.reference)
    except ValueError as exc:
        names = ", ".join(args.calibrations)
        raise CliError(f"{exc} (files: {names})") from None
    out.save(args.output)
    if args.plot:
        from ..report import plot_thermal  # imucalib.report costs 178 ms at start-up

        plot_thermal(out, args.plot)
    model = out.thermal
    if args.json:
        return print_json({"output": str(args.output), "reference_c": model.reference_c,
                           "range_c": list(model.range_c), "decisions": decisions,
                           "coefficients": {k: v.tolist() for k, v in model.coefficients.items()},
                           "verdict": out.fit.verdict.level, "verdict_reasons": out.fit.verdict.reasons})
    temps = ", ".join(f"{p['temperature_c']:.1f}" for p in model.points)
    print(f"combined {len(cals)} calibrations made at {temps} °C around {model.reference_c:g} °C "
          f"(verdict of the parts: {out.fit.verdict.level})")
    print(f"{'parameter':<32}{'order':>6}{'per °C':>14}{'per °C²':>14}{'slope/σ':>9}")
    for name, d in decisions.items():
        if not d["order"]:
            continue
        c = model.coefficients[name]
        z = d.get("slope_over_sigma")
        print(f"{name:<32}{d['order']:>6}{c[0]:>14.4g}{c[1]:>14.4g}{(f'{z:.1f}' if z else '-'):>9}")
    constant = [n for n, d in decisions.items() if not d["order"]]
    if constant:
        print(f"constant (no slope beyond 3σ, or no 1σ to judge one): {len(constant)} parameters")
    for reason in out.fit.verdict.reasons or []:
        print(f"  - {reason}")
    print(f"wrote {args.output}" + (f" and {args.plot}" if args.plot else ""))
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add thermal to the ``imucalib`` sub-commands."""
    p = sub.add_parser("thermal", help="combine calibrations at several temperatures into one that follows it",
                       description="Combine calibrations of one sensor made at several temperatures (each from a "
                       "recording with a temperature column) into one whose biases, scale factors and "
                       "misalignments are polynomials in temperature, fitted with each calibration's 1σ as weights; "
                       "a term is kept only where it exceeds 3σ (linear, or quadratic when that is significant). "
                       "'imucalib apply' and 'validate' then evaluate it at each sample's temperature, and "
                       "'imucalib export' writes a C header whose apply function takes the temperature.")
    p.add_argument("calibrations", nargs="+", metavar="CAL", help="calibration files (JSON), one per temperature")
    p.add_argument("-o", "--output", required=True, help="the combined calibration (JSON)")
    p.add_argument("--reference", type=float, default=25.0, metavar="C",
                   help="reference temperature of the polynomials (default: 25 °C)")
    p.add_argument("--plot", metavar="FILE", help="biases against temperature with the calibration points "
                   "(PNG, SVG or PDF; needs the plot extra)")
    p.add_argument("--json", action="store_true", help="print the result as JSON")
    p.set_defaults(func=cmd_thermal)
