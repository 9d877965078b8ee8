"""Reading recordings (CSV, imu_tk text, MATLAB) and writing them as CSV.

The readers are imported on first use (PEP 562): a submodule such as
:mod:`.atomic` can be imported without them.

:func:`read` here is the readers' level: the file's columns, no more (:mod:`.readers` picks the format;
:mod:`.csvreader`, :mod:`.imutk`, :mod:`.matfile`, :mod:`.phonepair`, :mod:`.fileblocks` and :mod:`.rosbag`
read them). What the command line reads — the magnetometer's columns attached, a ROS bag's magnetic-field
topic, a table of averaged poses, a simulated session directory — is :func:`imucalib.read`
(:mod:`imucalib.reading`), which takes :func:`read`'s options. A table of averaged poses (one row per
orientation) is read by :func:`read_pose_table` (:mod:`.posetable`).
"""

from __future__ import annotations

import importlib

__all__ = ["READERS", "PoseTable", "ReaderError", "guess_reader", "read", "read_pose_table", "write_csv",
           "write_pose_table"]

#: the public names and the module each comes from
_LAZY = {"READERS": ".readers", "ReaderError": ".readers", "guess_reader": ".readers", "read": ".readers",
         "write_csv": ".writers", "PoseTable": ".posetable", "read_pose_table": ".posetable",
         "write_pose_table": ".posetable"}


def __getattr__(name: str):
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'imucalib.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(module, __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
