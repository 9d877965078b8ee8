"""Reading one hour of a 400 Hz sensor_msgs/Imu topic (1.44 M messages) from ROS 1, ROS 2 SQLite and MCAP bags.

"after": :func:`imucalib.io.read` as it is (the bags' own indexes and numpy
over the message layout); "before": the same call with the bulk path turned
off, i.e. rosbags' iteration and deserialiser for every message, as the
reader did before. Prints JSON with the medians of ``--runs`` runs of each.

The bags are written once (about 20 s each) into a cache directory under the
system's temporary directory and reused by later runs (``--fresh`` rewrites
them). Their messages are serialised with numpy (the layout of
:mod:`imucalib.io.bagraw`) and the first of them is checked against the
rosbags deserialiser.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
from _common import median_time

import imucalib.io.rosbag as rosbag
from imucalib.io import bagraw, read

RATE = 400.0
T0_NS = 1_700_000_000_000_000_000
FRAME = b"imu_link"


def imu_messages(n: int, ros1: bool, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Record times [ns] and the serialised sensor_msgs/Imu messages (n, size) of a resting IMU."""
    rng = np.random.default_rng(seed)
    text = len(FRAME) + (0 if ros1 else 1)  # CDR counts the terminating NUL
    fields_at = 16 + text if ros1 else 4 + (12 + text + 7) // 8 * 8
    buf = np.zeros((n, fields_at + bagraw.IMU_FIELDS_BYTES), np.uint8)
    ns = T0_NS + np.round(np.arange(n) / RATE * 1e9).astype(np.int64)
    if ros1:
        buf[:, 0:4] = np.arange(n, dtype="<u4").view(np.uint8).reshape(n, 4)  # seq
    else:
        buf[:, 1] = 1  # CDR, little endian
    buf[:, 4:8] = (ns // 10**9).astype("<u4").view(np.uint8).reshape(n, 4)
    buf[:, 8:12] = (ns % 10**9).astype("<u4").view(np.uint8).reshape(n, 4)
    buf[:, 12:16] = np.frombuffer(np.uint32(text).astype("<u4").tobytes(), np.uint8)
    buf[:, 16:16 + len(FRAME)] = np.frombuffer(FRAME, np.uint8)
    values = np.zeros((n, 37))
    values[:, 3] = 1.0  # orientation w
    values[:, 13:16] = rng.normal(scale=0.01, size=(n, 3))  # angular_velocity [rad/s]
    values[:, 25:28] = [0.1, -0.2, 9.81] + rng.normal(scale=0.05, size=(n, 3))  # linear_acceleration [m/s²]
    buf[:, fields_at:] = values.astype("<f8").view(np.uint8).reshape(n, -1)
    return ns + 1_500_000, buf


def write_bag(path: Path, kind: str, n: int) -> None:
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = kind == "ros1"
    logged, buf = imu_messages(n, ros1)
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    check = (store.deserialize_ros1 if ros1 else store.deserialize_cdr)(buf[0].tobytes(), "sensor_msgs/msg/Imu")
    assert check.linear_acceleration.z == buf[0, -80:-72].view("<f8")[0]
    tmp = path.with_name(path.name + ".part")
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.unlink(missing_ok=True)
    if ros1:
        writer = Writer1(tmp)
    else:
        plugin = StoragePlugin.MCAP if kind == "mcap" else StoragePlugin.SQLITE3
        writer = Writer2(tmp, version=9, storage_plugin=plugin)
    with writer:
        conn = writer.add_connection("/imu/data", "sensor_msgs/msg/Imu", typestore=store)
        for k in range(n):
            writer.write(conn, int(logged[k]), buf[k].tobytes())
    if not ros1:
        for inner in tmp.iterdir():  # the storage file is named after its directory
            if inner.stem == tmp.name:
                inner.rename(tmp / (path.name + inner.suffix))
        meta = tmp / "metadata.yaml"
        meta.write_text(meta.read_text().replace(tmp.name, path.name))
    tmp.rename(path)


def library_only(fn):
    """``fn`` run with the bulk path off: rosbags' reader and deserialiser for every message."""
    saved = rosbag._fast_blocks, rosbag._open_for_reading, bagraw.decode_imu
    rosbag._fast_blocks, rosbag._open_for_reading, bagraw.decode_imu = (lambda *a: None), rosbag._open, (
        lambda *a: None)
    try:
        return fn()
    finally:
        rosbag._fast_blocks, rosbag._open_for_reading, bagraw.decode_imu = saved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=3600.0, help="length of the recording (default 1 h)")
    parser.add_argument("--kinds", default="ros1,sqlite,mcap")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--before-runs", type=int, default=3, help="runs of the old path (0: skip it)")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "imucalib-bench-rosbag")
    parser.add_argument("--fresh", action="store_true", help="write the bags again")
    args = parser.parse_args()
    n = int(round(args.seconds * RATE))
    args.cache.mkdir(parents=True, exist_ok=True)
    results = []
    for kind in args.kinds.split(","):
        path = args.cache / (f"imu_{n}_{kind}" + (".bag" if kind == "ros1" else ""))
        if args.fresh and path.exists():
            shutil.rmtree(path) if path.is_dir() else path.unlink()
        t0 = time.perf_counter()
        if not path.exists():
            write_bag(path, kind, n)
        written = time.perf_counter() - t0
        after, after_all = median_time(lambda p=path: read(p), args.runs, warm=True)
        rec = read(path)
        assert len(rec) == n, len(rec)
        row = {"kind": kind, "messages": n, "bag_mb": round(sum(f.stat().st_size for f in
                                                               ([path] if path.is_file() else path.iterdir()))
                                                           / 1e6, 1),
               "write_s": round(written, 1), "after_median_s": round(after, 2),
               "after_times_s": [round(t, 2) for t in after_all]}
        if args.before_runs:
            before, before_all = median_time(lambda p=path: library_only(lambda: read(p)), args.before_runs, warm=False)
            ref = library_only(lambda p=path: read(p))
            assert np.array_equal(ref.acc, rec.acc) and np.array_equal(ref.t, rec.t)
            row.update(before_median_s=round(before, 2), before_times_s=[round(t, 2) for t in before_all],
                       speedup=round(before / after, 1))
        results.append(row)
        print(json.dumps(row), flush=True)
    print(json.dumps({"benchmark": "rosbag_read", "rate_hz": RATE, "seconds": args.seconds, "results": results}))


if __name__ == "__main__":
    main()
