"""Commands for many devices: batch (a manifest into a calibration store) and store (list, get, export)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..io.atomic import refuse_overwriting_inputs
from ._common import EXIT_REJECTED, CliError, Progress, print_json

__all__ = ["add_scheduler_option", "register"]


def _workers(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number of processes; got {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected at least 1 process; got {text!r}")
    return n


def _temperature(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a temperature in °C; got {text!r}") from None
    if v != v or v in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"expected a finite temperature in °C; got {text!r}")
    return v


def add_scheduler_option(p: argparse.ArgumentParser) -> None:
    """``--scheduler local|ADDRESS``: run on a Dask LocalCluster or an existing Dask cluster."""
    p.add_argument("--scheduler", metavar="ADDRESS|local",
                   help="run on Dask (the cluster extra), one task per row or run: 'local' starts a LocalCluster on "
                   "this machine "
                   "(--workers processes, default one per core), an address such as tcp://HOST:8786 uses "
                   "that cluster's workers")


# ------------------------------------------------------------------ batch
def cmd_batch(args: argparse.Namespace) -> int:
    """``imucalib batch``: :func:`imucalib.batch.run_batch`, then the counts and the errors."""
    from ..batch import run_batch  # imucalib.batch costs 132 ms at start-up

    if args.scheduler is not None and args.scheduler != "local" and args.workers is not None:
        raise CliError("--workers applies to local processes and --scheduler local; a cluster at an "
                       "address has its own workers")
    with Progress(f"batch {Path(args.manifest).name}", unit="row") as bar:
        result = run_batch(args.manifest, args.store, workers=args.workers, scheduler=args.scheduler,
                           force=args.force, allow_urls=args.allow_urls, progress=bar)
    code = EXIT_REJECTED if result["failed"] else 0
    if args.json:
        print_json(result)
        return code
    v = result["verdicts"]
    print(f"{result['rows']} rows of {args.manifest} into {args.store}: {result['calibrated']} calibrated "
          f"({v['accepted']} accepted, {v['suspect']} suspect), {result['failed']} failed, "
          f"{result['skipped']} skipped (already in the store), in {result['seconds']:.1f} s")
    for e in result["errors"]:
        print(f"  line {e['line']} {e['device']}: {e['error']}")
    if result["failed"]:
        print("the errors are in the store too: imucalib store list --store " + str(args.store))
    return code


# ------------------------------------------------------------------ store
def _open(args: argparse.Namespace):
    from ..store import Store  # imucalib.store costs 88 ms at start-up

    return Store(args.store, readonly=True)


def cmd_store_list(args: argparse.Namespace) -> int:
    """``imucalib store list``: the records, oldest recording first."""
    with _open(args) as store:
        records = store.records(args.device)
    if args.json:
        return print_json(records)
    if not records:
        print(f"no records{f' of {args.device}' if args.device else ''} in {args.store}")
        return 0
    print(f"{'id':>5}  {'device':<16}{'recorded_at':<27}{'temp °C':>8}  {'method':<14}{'status':<8}{'verdict':<10}"
          "error")
    for r in records:
        temp = "" if r["temperature_c"] is None else f"{r['temperature_c']:.1f}"
        error = (r["error"] or "").replace("\n", " ")
        print(f"{r['id']:>5}  {r['device']:<16}{r['recorded_at'] or '-':<27}{temp:>8}  {r['method']:<14}"
              f"{r['status']:<8}{r['verdict'] or '-':<10}{error[:120]}")
    return 0


def cmd_store_get(args: argparse.Namespace) -> int:
    """``imucalib store get``: the accepted calibration of a device closest in time (or temperature)."""
    refuse_overwriting_inputs([args.output], [args.store])
    verdicts = ("accepted", "suspect") if args.include_suspect else ("accepted",)
    with _open(args) as store:
        cal, record = store.get(args.device, at=args.at, temperature=args.temperature, verdicts=verdicts)
    summary = {k: record[k] for k in ("id", "device", "recorded_at", "temperature_c", "method", "model",
                                      "verdict", "created")}
    if args.output is None:
        print(cal.to_json())
        return 0
    cal.save(args.output)
    if args.json:
        return print_json({**summary, "output": str(args.output)})
    when = record["recorded_at"] or "no recording time"
    temp = "" if record["temperature_c"] is None else f" at {record['temperature_c']:g} °C"
    print(f"wrote {args.output}: {record['device']}, recorded {when}{temp}, {record['method']}, "
          f"{record['verdict']} (record {record['id']})")
    return 0


def cmd_store_export(args: argparse.Namespace) -> int:
    """``imucalib store export``: the records as one JSON or CSV file, or a directory of calibration files."""
    refuse_overwriting_inputs([args.output], [args.store])
    with _open(args) as store:
        result = store.export(args.output, device=args.device)
    if args.json:
        return print_json(result)
    extra = f", {result['calibration_files']} calibration files" if result["form"] == "directory" else ""
    print(f"wrote {result['path']} ({result['form']}): {result['records']} records{extra}")
    return 0


# -------------------------------------------------------------------- parsers
def register(sub: argparse._SubParsersAction) -> None:
    """Add batch and store (list, get, export) to the ``imucalib`` sub-commands."""
    p = sub.add_parser(
        "batch", help="calibrate every recording of a manifest into a calibration store",
        description="Calibrate each row of a manifest CSV (columns device, files, and optionally method, "
        "model, reader, columns, acc_unit, gyro_unit, time_unit, rate, topic, variable, gravity, recorded_at, "
        "temperature_c; files ';'-separated, relative to the manifest) as 'imucalib calibrate' would, and "
        "store every result, or the row's error, in an SQLite store. A failing row never stops the batch. "
        "Rows already in the store (same device, time, settings and file contents) are skipped, so a batch "
        "that was interrupted is finished by running it again. Exits with 3 when a row failed. "
        "Rows name local files unless --allow-urls is given: a URL row (s3://, https://, ftp://, file://) "
        "makes the batch connect to the host it names, so allow URLs only for manifests you trust. With "
        "--scheduler, tasks and results travel pickled: whoever reaches the scheduler or its workers can run "
        "code there and in this process, so use only a scheduler of your own on a trusted network.")
    p.add_argument("manifest", help="manifest CSV, one recording per line")
    p.add_argument("--store", required=True, help="the store file (created if missing), e.g. fleet.sqlite")
    p.add_argument("--workers", type=_workers,
                   help="processes (default 1); with --scheduler local, the LocalCluster's workers")
    add_scheduler_option(p)
    p.add_argument("--allow-urls", nargs="?", const=True, default=False, metavar="SCHEMES",
                   help="read manifest rows that are fsspec URLs (needs fsspec): any scheme, or only those "
                   "listed, e.g. --allow-urls s3,gcs (default: URLs are refused, nothing runs)")
    p.add_argument("--force", action="store_true",
                   help="calibrate rows already in the store again, replacing their records")
    p.add_argument("--json", action="store_true",
                   help='print {"calibrated", "failed", "skipped", "verdicts", "errors", …} as JSON')
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser("store", help="look into a calibration store: list, get, export",
                       description="List the records of a calibration store, get the calibration of a "
                       "device, or export the store.")
    ss = p.add_subparsers(dest="store_command", required=True, metavar="STORE_COMMAND")

    q = ss.add_parser("list", help="the records (device, time, status, verdict, error)",
                      description="List the records of the store, oldest recording first.")
    q.add_argument("--store", required=True, help="the store file")
    q.add_argument("--device", help="only this device's records")
    q.add_argument("--json", action="store_true", help="print the records as a JSON list")
    q.set_defaults(func=cmd_store_list)

    q = ss.add_parser("get", help="a device's accepted calibration closest in time or temperature",
                      description="Write the accepted calibration of DEVICE recorded closest to --at (default: "
                      "the latest), or, with --temperature, the one recorded closest to that temperature "
                      "(ties go to the closest in time). Without -o the calibration is printed as JSON.")
    q.add_argument("device", help="the device, as named in the manifest")
    q.add_argument("--store", required=True, help="the store file")
    q.add_argument("--at", metavar="TIME", help="ISO date or time, e.g. 2024-06-01 or 2024-06-01T14:30")
    q.add_argument("--temperature", type=_temperature, metavar="C", help="temperature [°C]")
    q.add_argument("--include-suspect", action="store_true", help="suspect calibrations may be used too")
    q.add_argument("-o", "--output", help="write the calibration file (JSON) here")
    q.add_argument("--json", action="store_true", help="with -o: print the chosen record as JSON")
    q.set_defaults(func=cmd_store_get)

    q = ss.add_parser("export", help="write the store out as JSON, CSV or a directory of calibration files",
                      description="OUT.json: one JSON document with every record and its calibration; "
                      "OUT.csv: one line per record with every calibration parameter as a column; any other "
                      "name: a new directory with index.json and DEVICE/RECORDED_AT_ID.json calibration files "
                      "(usable by 'imucalib apply').")
    q.add_argument("--store", required=True, help="the store file")
    q.add_argument("-o", "--output", required=True, help="OUT.json, OUT.csv or a new directory")
    q.add_argument("--device", help="only this device's records")
    q.add_argument("--json", action="store_true", help="print a JSON summary")
    q.set_defaults(func=cmd_store_export)
