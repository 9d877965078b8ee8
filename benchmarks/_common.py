"""Shared helpers of the benchmark scripts: timing and the real data location."""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def median_time(fn: Callable[[], object], runs: int, warm: bool = True) -> tuple[float, list[float]]:
    """Median wall time [s] of ``runs`` calls (after one warm-up call unless ``warm`` is False) and all times."""
    if warm:
        fn()
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def require_data(sub: str) -> Path:
    path = DATA / sub
    if not path.is_dir():
        print(f'{{"skipped": "{path} not present (needs ../shared/data)"}}')
        sys.exit(0)
    return path
