"""A calibration in the forms other tools and devices read.

* :func:`to_c` — a C99 header that corrects samples on the device (:mod:`.c`);
* :func:`to_openvins` — the ``imu0`` intrinsics of OpenVINS's ``kalibr_imu_chain.yaml``;
* :func:`to_kalibr` — Kalibr's IMU entry with its scale-misalignment intrinsics
  (:mod:`.estimators`, with :func:`read_noise` for the noise entries);
* :func:`to_imutk` — imu_tk's two parameter files (:mod:`.imutk`).

All but the C header hold a linear model only; what a format cannot hold
(nonlinear scales, a g-sensitivity imu_tk has no place for, raw counts without
the driver's scale) raises :class:`ExportError` with the reason, never a
silently different calibration. :mod:`.linear` has the shared algebra.
"""

from __future__ import annotations

from .c import to_c
from .estimators import OPENVINS_MODELS, read_noise, to_kalibr, to_openvins
from .imutk import imutk_paths, to_imutk
from .linear import ExportError, linear_form

__all__ = ["FORMATS", "OPENVINS_MODELS", "ExportError", "imutk_paths", "linear_form", "read_noise", "to_c",
           "to_imutk", "to_kalibr", "to_openvins"]

#: export formats by name
FORMATS = ("c", "openvins", "kalibr", "imutk")
