"""Several files of the same sensor, one per pose, read as blocks of one recording."""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..recording import ImucalibWarning, Recording
from .csvreader import BLOCK_GAP_STEPS
from .errors import ReaderError

__all__ = ["read_file_blocks"]


def read_file_blocks(paths: Sequence[Path], reader: str, columns, acc_unit, gyro_unit, rate, variable, time_unit,
                     topic, *, read: Callable[..., Recording]) -> Recording:
    """Several files of the same sensor, one per pose (MATLAB's ``accelcal(XUP, XDOWN, …)``), as one recording.

    Each file is read as one file is, with its own time base; the blocks follow each other in the order given,
    each :data:`BLOCK_GAP_STEPS` median sampling steps after the one before, and ``metadata["blocks"]`` holds
    their rows ``[start, stop)``. They must have the same sensors, units and columns. A note repeated by every
    file is shown once. Each file is read by ``read`` (:func:`.readers.read`).
    """
    if topic is not None:
        raise ReaderError(f"topic applies to ROS bags; the {reader} reader has none")
    twice = [p for i, p in enumerate(paths) if p.resolve() in {q.resolve() for q in paths[:i]}]
    if twice:
        raise ReaderError(f"{twice[0]} is given twice; several files are read as blocks of one recording (one pose "
                          "each), each file once")
    recs = _read_each(paths, read, dict(reader=reader, columns=columns, acc_unit=acc_unit, gyro_unit=gyro_unit,
                                        rate=rate, variable=variable, time_unit=time_unit))
    _check_alike(paths, recs)
    first = recs[0]
    steps = np.concatenate([np.diff(r.t) for r in recs])
    gap = BLOCK_GAP_STEPS * (float(np.median(steps)) if steps.size else 1.0)
    times, start, blocks, row = [], 0.0, [], 0
    for r in recs:
        times.append(r.t - r.t[0] + start)
        start = float(times[-1][-1]) + gap
        blocks.append([row, row + len(r)])
        row += len(r)
    keys = [k for k in first.extra if all(k in r.extra for r in recs)]
    left = sorted({k for r in recs for k in r.extra} - set(keys))
    if left:
        warnings.warn(f"the column(s) {', '.join(left)} are not in every file: left out", ImucalibWarning,
                      stacklevel=3)
    temps = [r.temperature for r in recs]
    meta = {**first.metadata, "source": [str(p) for p in paths], "reader": reader, "blocks": blocks,
            "block_files": len(paths)}
    meta.pop("source_layout", None)
    warnings.warn(f"read {len(paths)} files as blocks of one recording, one pose each, in the order given (each "
                  f"with its own time base); {len(paths)} files joined: the gaps between them are not used for "
                  "integration", ImucalibWarning, stacklevel=3)
    return Recording(
        t=np.concatenate(times), acc=np.concatenate([r.acc for r in recs]),
        gyro=None if first.gyro is None else np.concatenate([r.gyro for r in recs]),
        acc_unit=first.acc_unit, gyro_unit=first.gyro_unit,
        temperature=None if any(x is None for x in temps) else np.concatenate(temps),
        extra={k: np.concatenate([r.extra[k] for r in recs]) for k in keys}, metadata=meta,
    )


def _read_each(paths: Sequence[Path], read: Callable[..., Recording], options: dict) -> list[Recording]:
    """Each file read as one file is; a note that every file repeats is shown once (with the count)."""
    recs = []
    notes: dict[str, list] = {}  # a note's text without the file and its figures → [first note, files it is in]
    for p in paths:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ImucalibWarning)
            recs.append(read(p, **options))
        for w in caught:
            key = re.sub(r"[-+]?\d[\d.]*(?:e[-+]?\d+)?", "#", str(w.message).replace(str(p), ""))
            notes.setdefault(key, [w, 0])[1] += 1
    for w, count in notes.values():
        warnings.warn(f"{w.message}" + (f" (and in {count - 1} more of the files)" if count > 1 else ""),
                      w.category, stacklevel=4)
    return recs


def _check_alike(paths: Sequence[Path], recs: list[Recording]) -> None:
    """The files' recordings have the same sensors, units and columns (blocks of one recording must)."""
    first = recs[0]
    for p, rec in zip(paths[1:], recs[1:], strict=True):
        has = ("a gyroscope" if first.gyro is not None else "no gyroscope",
               "a gyroscope" if rec.gyro is not None else "no gyroscope")
        for what, a, b in (("has", *has), ("has its accelerometer in", first.acc_unit, rec.acc_unit),
                           ("has its gyroscope in", first.gyro_unit if first.gyro is not None else None,
                            rec.gyro_unit if rec.gyro is not None else None),
                           ("has the columns", first.metadata.get("column_names"), rec.metadata.get("column_names"))):
            if a != b:
                a, b = (", ".join(v) if isinstance(v, list) else str(v) for v in (a, b))
                raise ReaderError(f"several files are read as blocks (one pose each) of one recording, so they must "
                                  f"match: {p} {what} {b}, {paths[0]} {what} {a}")
