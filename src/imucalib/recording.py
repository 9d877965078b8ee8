"""Recordings of an IMU: time, accelerometer and gyroscope samples, with units.

Samples are rows: ``t`` has shape (N,) in seconds, ``acc`` and ``gyro`` have
shape (N, 3). A recording may be in raw sensor units (``"counts"``) or in
physical units; calibrations map raw units to SI (m/s², rad/s).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .constants import STANDARD_GRAVITY

__all__ = [
    "ACC_UNITS",
    "GYRO_UNITS",
    "MAG_UNITS",
    "ImucalibWarning",
    "Interval",
    "Recording",
    "STANDARD_GRAVITY",
    "dataframe_columns",
    "require_pandas",
]


#: accepted accelerometer units and their factor to m/s² (``"g"`` uses ``gravity``)
ACC_UNITS = ("counts", "g", "m/s^2")
#: accepted gyroscope units and their factor to rad/s
GYRO_UNITS = ("counts", "deg/s", "rad/s")
#: accepted magnetometer units (µT and gauss are physical, 1 gauss = 100 µT; "normalised": calibrated, |m| = 1)
MAG_UNITS = ("counts", "uT", "gauss", "normalised")


class ImucalibWarning(UserWarning):
    """Warnings emitted by imucalib (data changed, weak geometry, poor fit...).

    Examples
    --------
    A warning says what was done to the data and why; here the gyroscope's stream, stamped 5 ms after the
    accelerometer's, is interpolated onto its times:

    >>> import warnings
    >>> import numpy as np
    >>> from imucalib import ImucalibWarning, Recording
    >>> t = np.arange(5) / 100.0
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always", ImucalibWarning)
    ...     rec = Recording.from_streams(t, np.zeros((5, 3)), t + 0.005, np.zeros((5, 3)))
    >>> print(caught[0].message)
    accelerometer and gyroscope timestamps differ: the gyroscope was linearly interpolated ...

    ``warnings.simplefilter("error", ImucalibWarning)`` makes them errors instead.
    """


def require_pandas(what: str):
    """The pandas module, or a ValueError saying which extra installs it."""
    try:
        import pandas  # optional: pip install imucalib[pandas]
    except ImportError:
        raise ValueError(f'{what} needs pandas: pip install "imucalib[pandas]" (or pandas)') from None
    return pandas


def dataframe_columns(recording: Recording) -> dict[str, np.ndarray]:
    """Name → column of :meth:`Recording.to_dataframe`."""
    cols: dict[str, np.ndarray] = {"t [s]": recording.t}
    for sensor, values, unit in (("a", recording.acc, recording.acc_unit), ("g", recording.gyro, recording.gyro_unit)):
        if values is None:  # an accelerometer-only recording has no gyroscope columns
            continue
        for i, axis in enumerate("xyz"):
            cols[f"{sensor}{axis} [{unit}]"] = values[:, i]
    if recording.temperature is not None:
        cols["temperature [C]"] = recording.temperature
    for name, values in recording.extra.items():
        if name in cols or (recording.temperature is not None and values is recording.temperature):
            continue
        cols[name] = values
    return cols


def _check_unit(unit: str, allowed: tuple[str, ...], what: str) -> str:
    aliases = {"m/s2": "m/s^2", "m/s²": "m/s^2", "dps": "deg/s", "rad/s^1": "rad/s", "raw": "counts",
               "µT": "uT", "microtesla": "uT", "G": "gauss", "Gs": "gauss"}
    unit = aliases.get(unit, unit)
    if unit not in allowed:
        raise ValueError(f"{what} unit must be one of {', '.join(allowed)}; got {unit!r}")
    return unit


@dataclass(frozen=True)
class Interval:
    """A half-open range of sample indices ``[start, stop)`` of a recording.

    ``kind`` says what the samples are: ``"static"``, ``"motion"``,
    ``"weightless"`` or ``"test"``.

    Examples
    --------
    The second half of a 200-sample recording, as the pose detectors give them
    (:func:`imucalib.segment.detect_intervals`):

    >>> import numpy as np
    >>> from imucalib import Interval, Recording
    >>> rec = Recording(np.arange(200) / 100.0, acc=np.zeros((200, 3)), gyro=np.zeros((200, 3)))
    >>> pose = Interval(100, 200)
    >>> len(pose), pose.kind, rec[pose].t[:2]
    (100, 'static', array([1.  , 1.01]))
    >>> Interval(5, 5)
    Traceback (most recent call last):
        ...
    ValueError: Interval stop (5) must exceed start (5)
    """

    start: int
    stop: int
    kind: str = "static"

    def __post_init__(self) -> None:
        if self.stop <= self.start:
            raise ValueError(f"Interval stop ({self.stop}) must exceed start ({self.start})")

    def __len__(self) -> int:
        return self.stop - self.start

    @property
    def slice(self) -> slice:
        return slice(self.start, self.stop)

    def to_dict(self) -> dict[str, Any]:
        return {"start": self.start, "stop": self.stop, "kind": self.kind}


@dataclass
class Recording:
    """Time-stamped accelerometer and gyroscope samples on one time base.

    Parameters
    ----------
    t : (N,) array_like
        Sample times [s], strictly increasing.
    acc, gyro : (N, 3) array_like
        Accelerometer and gyroscope samples in ``acc_unit`` and ``gyro_unit``;
        ``gyro`` is None for an accelerometer-only recording (a logger or board
        with no gyroscope: :attr:`has_gyroscope` is False).
    acc_unit : {"counts", "g", "m/s^2"}
    gyro_unit : {"counts", "deg/s", "rad/s"}
    temperature : (N,) array_like, optional
        Sensor temperature [°C].
    extra : dict of (N,) arrays, optional
        Other columns of the source, kept so that writers can pass them on.
    metadata : dict, optional
        Free-form information (source file, reader, device...).
    mag : (N, 3) array_like, optional
        Magnetometer samples in ``mag_unit`` (None: the IMU has none, or it was not read).
    mag_unit : {"counts", "uT", "gauss", "normalised"}

    Raises
    ------
    ValueError
        For arrays whose shapes do not match ``t``, non-finite values, no samples, times that do not
        increase, or an unknown unit.

    Examples
    --------
    Two seconds at 100 Hz of a sensor lying still, z up, built from arrays (readers build them from files):

    >>> import numpy as np
    >>> from imucalib import Recording
    >>> t = np.arange(200) / 100.0
    >>> rec = Recording(t, acc=np.tile([0.0, 0.0, 1.0], (200, 1)), gyro=np.zeros((200, 3)),
    ...                 acc_unit="g", gyro_unit="deg/s")
    >>> len(rec), round(rec.rate), rec.duration, rec.has_gyroscope
    (200, 100, 1.99, True)
    >>> Recording(t[::-1], acc=np.zeros((200, 3)), gyro=None)
    Traceback (most recent call last):
        ...
    ValueError: timestamps must be strictly increasing; sample 1 is decreasing (t=1.99 then 1.98)
    """

    t: np.ndarray
    acc: np.ndarray
    gyro: np.ndarray | None
    acc_unit: str = "counts"
    gyro_unit: str = "counts"
    temperature: np.ndarray | None = None
    extra: dict[str, np.ndarray] = field(default_factory=dict)
    metadata: dict[str, Any] = field(default_factory=dict)
    mag: np.ndarray | None = None
    mag_unit: str = "counts"

    def __post_init__(self) -> None:
        self.t = np.asarray(self.t, dtype=np.float64)
        self.acc = np.asarray(self.acc, dtype=np.float64)
        if self.gyro is not None:
            self.gyro = np.asarray(self.gyro, dtype=np.float64)
        if self.t.ndim != 1:
            raise ValueError(f"t must have shape (N,); got {self.t.shape}")
        n = self.t.shape[0]
        for name in ("acc", "gyro") if self.gyro is not None else ("acc",):
            arr = getattr(self, name)
            if arr.shape != (n, 3):
                raise ValueError(f"{name} must have shape ({n}, 3) to match t; got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                row = int(np.nonzero(~np.all(np.isfinite(arr), axis=1))[0][0])
                raise ValueError(f"{name} has a non-finite value (NaN or inf) at sample {row}")
        if n == 0:
            raise ValueError("a Recording needs at least one sample; got none")
        if not np.all(np.isfinite(self.t)):
            raise ValueError("t has a non-finite value (NaN or inf)")
        if n > 1:
            dt = np.diff(self.t)
            if np.any(dt <= 0):
                i = int(np.nonzero(dt <= 0)[0][0]) + 1
                what = "duplicated" if dt[i - 1] == 0 else "decreasing"
                raise ValueError(
                    f"timestamps must be strictly increasing; sample {i} is {what} "
                    f"(t={float(self.t[i - 1]):.10g} then {float(self.t[i]):.10g})"
                )
        self.acc_unit = _check_unit(self.acc_unit, ACC_UNITS, "accelerometer")
        self.gyro_unit = _check_unit(self.gyro_unit, GYRO_UNITS, "gyroscope")
        if self.temperature is not None:
            self.temperature = np.asarray(self.temperature, dtype=np.float64)
            if self.temperature.shape != (n,):
                raise ValueError(f"temperature must have shape ({n},); got {self.temperature.shape}")
        if self.mag is not None:
            self.mag = np.asarray(self.mag, dtype=np.float64)
            if self.mag.shape != (n, 3):
                raise ValueError(f"mag must have shape ({n}, 3) to match t; got {self.mag.shape}")
            if not np.all(np.isfinite(self.mag)):
                row = int(np.nonzero(~np.all(np.isfinite(self.mag), axis=1))[0][0])
                raise ValueError(f"mag has a non-finite value (NaN or inf) at sample {row}")
        self.mag_unit = _check_unit(self.mag_unit, MAG_UNITS, "magnetometer")
        for key, col in list(self.extra.items()):
            col = np.asarray(col)
            if col.shape[:1] != (n,):
                raise ValueError(f"extra column {key!r} must have {n} rows; got {col.shape}")
            self.extra[key] = col

    # ------------------------------------------------------------------ basics
    def __len__(self) -> int:
        return self.t.shape[0]

    @property
    def has_gyroscope(self) -> bool:
        """False for an accelerometer-only recording (``gyro`` is None)."""
        return self.gyro is not None

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.t[-1] - self.t[0])

    @property
    def rate(self) -> float:
        """Median sampling rate [Hz], ``1 /`` :attr:`step`."""
        return float(1.0 / self.step)

    @property
    def step(self) -> float:
        """Median sampling interval [s] (computed once per time array: the median of a long recording's steps
        costs two copies of it)."""
        if len(self) < 2:
            raise ValueError("the sampling rate needs at least two samples")
        cached = self.__dict__.get("_step")
        if cached is not None and cached[0] is self.t:
            return cached[1]
        step = float(np.median(np.diff(self.t)))
        self.__dict__["_step"] = (self.t, step)
        return step

    def __getitem__(self, index: slice | Interval) -> Recording:
        """Samples ``index`` (a slice or an :class:`Interval`) as a new Recording."""
        if isinstance(index, Interval):
            index = index.slice
        if not isinstance(index, slice):
            raise TypeError("a Recording is indexed by a slice or an Interval")
        return Recording(
            t=self.t[index],
            acc=self.acc[index],
            gyro=None if self.gyro is None else self.gyro[index],
            acc_unit=self.acc_unit,
            gyro_unit=self.gyro_unit,
            temperature=None if self.temperature is None else self.temperature[index],
            extra={k: v[index] for k, v in self.extra.items()},
            metadata={k: v for k, v in self.metadata.items() if k not in ("blocks", "time_original")},  # the whole's
            mag=None if self.mag is None else self.mag[index],
            mag_unit=self.mag_unit,
        )

    # ------------------------------------------------------------------ pandas
    def to_dataframe(self):
        """The recording as a pandas DataFrame (needs the ``pandas`` extra).

        Columns ``t [s]``, ``ax [unit]`` … ``gz [unit]``, ``temperature [C]``
        when there is one, then the extra columns by their names: the names
        :func:`imucalib.io.read` recognises, so ``read(rec.to_dataframe())``
        gives this recording back. The arrays are copied.
        """
        pd = require_pandas("Recording.to_dataframe")
        return pd.DataFrame(dataframe_columns(self), copy=True)

    # ------------------------------------------------------------------ units
    def in_si(self, gravity: float = STANDARD_GRAVITY) -> Recording:
        """Convert g → m/s² and deg/s → rad/s; raw counts are left as they are."""
        acc = self.acc * gravity if self.acc_unit == "g" else self.acc
        gyro = np.deg2rad(self.gyro) if self.gyro_unit == "deg/s" and self.gyro is not None else self.gyro
        return Recording(
            t=self.t,
            acc=acc,
            gyro=gyro,
            acc_unit="m/s^2" if self.acc_unit == "g" else self.acc_unit,
            gyro_unit="rad/s" if self.gyro_unit == "deg/s" else self.gyro_unit,
            temperature=self.temperature,
            extra=dict(self.extra),
            metadata=dict(self.metadata),
            mag=self.mag,
            mag_unit=self.mag_unit,
        )

    # ------------------------------------------------------------- alignment
    @classmethod
    def from_streams(
        cls,
        t_acc: np.ndarray,
        acc: np.ndarray,
        t_gyro: np.ndarray,
        gyro: np.ndarray,
        **kwargs: Any,
    ) -> Recording:
        """Build a Recording from separately time-stamped accelerometer and gyroscope streams.

        When the timestamps differ, the gyroscope is linearly interpolated onto
        the accelerometer's time base, restricted to the span both streams
        cover, and an :class:`ImucalibWarning` says how many samples were
        interpolated and how many accelerometer samples fell outside that span.
        """
        t_acc = np.asarray(t_acc, dtype=np.float64)
        t_gyro = np.asarray(t_gyro, dtype=np.float64)
        acc = np.asarray(acc, dtype=np.float64)
        gyro = np.asarray(gyro, dtype=np.float64)
        for name, tt in (("accelerometer", t_acc), ("gyroscope", t_gyro)):
            if tt.size and np.any(np.diff(tt) <= 0):
                i = int(np.nonzero(np.diff(tt) <= 0)[0][0]) + 1
                raise ValueError(f"{name} timestamps must be strictly increasing; sample {i} is not")
        if t_acc.shape == t_gyro.shape and np.array_equal(t_acc, t_gyro):
            return cls(t=t_acc, acc=acc, gyro=gyro, **kwargs)
        lo = max(t_acc[0], t_gyro[0])
        hi = min(t_acc[-1], t_gyro[-1])
        if hi <= lo:
            raise ValueError(
                "the accelerometer and gyroscope streams do not overlap in time "
                f"(accelerometer {t_acc[0]:.6g}..{t_acc[-1]:.6g} s, "
                f"gyroscope {t_gyro[0]:.6g}..{t_gyro[-1]:.6g} s)"
            )
        keep = (t_acc >= lo) & (t_acc <= hi)
        t = t_acc[keep]
        gyro_i = np.column_stack([np.interp(t, t_gyro, gyro[:, k]) for k in range(3)])
        dropped = int(t_acc.size - t.size)
        warnings.warn(
            f"accelerometer and gyroscope timestamps differ: the gyroscope was linearly "
            f"interpolated onto the {t.size} accelerometer timestamps"
            + (f"; {dropped} accelerometer samples outside the gyroscope's span were left out"
               if dropped else ""),
            ImucalibWarning,
            stacklevel=2,
        )
        extra = kwargs.pop("extra", {}) or {}
        extra = {k: np.asarray(v)[keep] for k, v in extra.items()}
        temperature = kwargs.pop("temperature", None)
        if temperature is not None:
            temperature = np.asarray(temperature)[keep]
        if kwargs.get("mag") is not None:  # the magnetometer shares the accelerometer's time stamps
            kwargs["mag"] = np.asarray(kwargs["mag"])[keep]
        return cls(t=t, acc=acc[keep], gyro=gyro_i, extra=extra, temperature=temperature, **kwargs)
