"""Calibration methods, one module per published method, behind one entry point.

``calibrate(data, method=NAME, ...)`` runs a method on a :class:`Recording`
(or on a simulated session, whose ``recording`` is used) and returns a
:class:`~imucalib.calibration.Calibration`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..calibration import Calibration
from ..recording import STANDARD_GRAVITY, Recording

__all__ = ["METHODS", "calibrate", "method_names"]


def _tedaldi2014(data, *, model: str | None, gravity: float, **options: Any) -> Calibration:
    from . import tedaldi2014

    if model not in (None, "linear"):
        raise ValueError(f"tedaldi2014 fits the linear model only; got model={model!r}")
    return tedaldi2014.calibrate(_recording_of(data), gravity=gravity, **options)


def _zhang2021(data, *, model: str | None, gravity: float, **options: Any) -> Calibration:
    from . import zhang2021

    weightless = options.pop("weightless", None)
    if weightless is None and not isinstance(data, Recording):
        weightless = getattr(data, "weightless", None)
    if "intervals" not in options and not isinstance(data, Recording):
        segments = getattr(data, "segments", None)
        noise = getattr(data, "noise", None)
        # noise-free simulations cannot set a detector threshold: use their layout
        if segments is not None and noise is not None and not any(_noise_values(noise)):
            options["intervals"] = [s for s in segments if s.kind == "static"]
            options.setdefault("noise_weights", False)
    return zhang2021.calibrate(_recording_of(data), weightless=weightless,
                               model=model or "all", gravity=gravity, **options)


def _noise_values(noise) -> list[float]:
    if isinstance(noise, dict):
        return [float(v) for v in noise.values()]
    return [float(noise)]


def _wang2019(data, *, model: str | None, gravity: float, **options: Any) -> Calibration:
    from . import wang2019

    if model not in (None, "wang2019"):
        raise ValueError(f"wang2019 has one model; got model={model!r}")
    if not hasattr(data, "positions_acc"):
        raise ValueError("wang2019 needs turntable data (static position means and clockwise/"
                         "counter-clockwise turn integrals), as the wang2019 scenario provides; "
                         "it does not run on a free-hand recording")
    return wang2019.calibrate(data, gravity=gravity, **_accepted(wang2019.calibrate, options))


def _linear_only(module_name: str) -> Callable[..., Calibration]:
    def run(data, *, model: str | None, gravity: float, **options: Any) -> Calibration:
        import importlib

        if model not in (None, "linear"):
            raise ValueError(f"{module_name} fits the linear model only; got model={model!r}")
        module = importlib.import_module(f"{__name__}.{module_name}")
        return module.calibrate(_recording_of(data), gravity=gravity,
                                **_accepted(module.calibrate, options))

    return run


#: method name → callable(data, *, model, gravity, **options) → Calibration
METHODS: dict[str, Callable[..., Calibration]] = {
    "tedaldi2014": _tedaldi2014,
    "zhang2021": _zhang2021,
    "wang2019": _wang2019,
    "ellipsoid": _linear_only("ellipsoid"),
    "six_position": _linear_only("six_position"),
    "qureshi2017": _linear_only("qureshi2017"),
    "ferraris": _linear_only("ferraris"),
}


def method_names() -> list[str]:
    """Names accepted by :func:`calibrate`."""
    return sorted(METHODS)


def _accepted(fn: Callable, options: dict) -> dict:
    """``options`` without ``progress`` when ``fn`` does not report progress."""
    import inspect

    if "progress" in options and "progress" not in inspect.signature(fn).parameters:
        options = {k: v for k, v in options.items() if k != "progress"}
    return options


def _recording_of(data) -> Recording:
    if isinstance(data, Recording):
        return data
    rec = getattr(data, "recording", None)
    if isinstance(rec, Recording):
        return rec
    if hasattr(data, "positions_acc"):
        raise ValueError("this is a turntable session (static position means and turn integrals), not a "
                         "recording of samples: only --method wang2019 calibrates it")
    raise TypeError(f"expected a Recording or a simulated session; got {type(data).__name__}")


def calibrate(
    data,
    *,
    method: str,
    model: str | None = None,
    gravity: float = STANDARD_GRAVITY,
    **options: Any,
) -> Calibration:
    """Calibrate with the named method.

    Parameters
    ----------
    data : Recording or session
        Raw readings (a simulated session contributes its ``recording`` and,
        for methods that use them, its weightless segments).
    method : str
        One of :func:`method_names`.
    model : str, optional
        Model variant where the method has several (e.g. ``"linear"``, ``"cubic"``).
    gravity : float
        Local gravity [m/s²].
    **options
        Method-specific keyword options (see each method's ``calibrate``).
    """
    try:
        fn = METHODS[method]
    except KeyError:
        raise ValueError(
            f"unknown method {method!r}; choose one of {', '.join(method_names())}"
        ) from None
    return fn(data, model=model, gravity=gravity, **options)
