r"""Sensor error models: the canonical model family of imucalib.

For one sensor triad with raw readings ``u`` (any unit, e.g. counts) — Zhang
2021, eqs. (1), (2), (5) and (7), with the bias subtracted:

.. math::

    \mathbf a = \mathbf T_a\, \mathbf f_a(\mathbf u_a - \mathbf b_a), \qquad
    \boldsymbol\omega = \mathbf T_g\, \mathbf f_g(\mathbf u_g - \mathbf b_g - \mathbf G\, \mathbf a), \qquad
    f(\mathbf x)_i = k_{1,i} x_i + k_{2,i} x_i^2 + k_{3,i} x_i^3

or, as plain text::

    accelerometer:  a = T_a · f_a(u_a − b_a)
    gyroscope:      ω = T_g · f_g(u_g − b_g − G · a)
    f(x)_i = k1_i·x_i + k2_i·x_i² + k3_i·x_i³

``a`` is in m/s², ``ω`` in rad/s. ``T`` is a misalignment matrix with unit
diagonal whose free entries depend on its *shape*:

* ``"upper"`` — unit upper-triangular, 3 terms (xy, xz, yz): the accelerometer
  defines its own orthogonal frame (Tedaldi 2014; Zhang 2021, eq. 4);
* ``"full"`` — unit diagonal, 6 off-diagonal terms (Zhang 2021, eq. 8);
* ``"lower"`` — unit lower-triangular, 3 terms (yx, zx, zy) (Wang 2019, eqs. 5, 8).

The bias ``b`` is in raw units and is *subtracted*. ``G`` (gyroscope only) is
the g-sensitivity in raw gyroscope units per m/s², multiplying the calibrated
specific force. Zhang 2021 writes ``f(u + b)``: its ``b`` is the negative of
ours (Zhang 2021, eqs. 1–8).

Parameters are named ``<sensor>.<key>.<component>``: keys ``misalignment``,
``scale``, ``scale_quadratic``, ``scale_cubic``, ``bias``, ``g_sensitivity``;
components ``x``/``y``/``z`` for vectors and row-then-column (``xz``) for
matrices; the lever arm is ``lever_arm.x`` etc.

The magnetometer has its own model (:class:`MagnetometerModel`), expressed in
the accelerometer's frame:

.. math::

    \mathbf m = F\, \mathbf O\, \mathbf S\, (\mathbf u_m - \mathbf b_m)

with ``b_m`` the hard-iron bias (raw units), ``S`` the symmetric positive
definite soft-iron matrix that maps the raw readings onto the unit sphere,
``O`` an orthogonal matrix (determinant ±1: the magnetometer die's axes may be
permuted and reflected relative to the accelerometer's, then slightly rotated)
and ``F`` the field's magnitude in the calibrated unit (1 for ``"normalised"``).
Its parameters are ``magnetometer.bias.x``, ``magnetometer.soft_iron.xy``
(``xx yy zz xy xz yz``), ``magnetometer.alignment.xy`` (the 9 entries of ``O``)
and ``magnetometer.field``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

__all__ = [
    "AXES",
    "MISALIGNMENT_SHAPES",
    "MagnetometerModel",
    "NotInvertibleError",
    "TriadModel",
    "misalignment_entries",
]

AXES = ("x", "y", "z")

#: free (row, column) entries of each misalignment shape
MISALIGNMENT_SHAPES: dict[str, tuple[tuple[int, int], ...]] = {
    "upper": ((0, 1), (0, 2), (1, 2)),
    "full": ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)),
    "lower": ((1, 0), (2, 0), (2, 1)),
}


#: rows from which :meth:`TriadModel.forward` lays an array out an axis to a row (below, the layout's copies cost more)
#: (about 6 % of calibrating the Xsens session, a profile: 8 ms of 141 without it; kept with the scan's means,
#: :class:`imucalib.segment.detect.IntervalMeans` says why)
_AXIS_ROWS = 256


class NotInvertibleError(ValueError):
    """A scale-factor polynomial is not monotonic over the range asked of it.

    Examples
    --------
    A cubic scale factor ``f(x) = x − 0.1 x³`` turns back beyond ``x = ±1.83``, so it never reaches 5:

    >>> import numpy as np
    >>> from imucalib.models import NotInvertibleError, TriadModel
    >>> model = TriadModel(scale=[1.0, 1.0, 1.0], scale_cubic=[-0.1, 0.0, 0.0])
    >>> try:
    ...     model.inverse(np.array([[5.0, 0.0, 0.0]]))
    ... except NotInvertibleError as exc:
    ...     print(exc)
    the x-axis scale polynomial f(x) = 1x + 0x² + -0.1x³ is not monotonic beyond the raw range ...
    """


def misalignment_entries(shape: str) -> tuple[tuple[int, int], ...]:
    """Free (row, column) entries of a misalignment ``shape``."""
    try:
        return MISALIGNMENT_SHAPES[shape]
    except KeyError:
        raise ValueError(
            f"misalignment shape must be one of {', '.join(MISALIGNMENT_SHAPES)}; got {shape!r}"
        ) from None


def _vec(x, name: str) -> np.ndarray:
    a = np.array(x, dtype=np.float64).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"{name} must have 3 entries; got shape {np.shape(x)}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite; got {a}")
    return a


def _mat(x, name: str) -> np.ndarray:
    a = np.array(x, dtype=np.float64)
    if a.shape != (3, 3):
        raise ValueError(f"{name} must be a 3x3 matrix; got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must be finite; got {a}")
    return a


def _fixed_entries(shape: str) -> np.ndarray:
    """(3, 3) mask of the off-diagonal entries a misalignment of ``shape`` holds at zero."""
    mask = ~np.eye(3, dtype=bool)
    for i, j in MISALIGNMENT_SHAPES[shape]:
        mask[i, j] = False
    return mask


#: per misalignment shape, the off-diagonal entries it holds at zero
_FIXED = {shape: _fixed_entries(shape) for shape in MISALIGNMENT_SHAPES}

#: the vector fields of a :class:`TriadModel`, in the order its checks read them
_VECTORS = ("scale", "scale_quadratic", "scale_cubic", "bias", "output_bias")


@dataclass(frozen=True)
class TriadModel:
    """Error model of one sensor triad (see module docstring).

    Parameters
    ----------
    misalignment : (3, 3) array_like
        ``T``, unit diagonal; entries outside ``shape`` must be zero.
    scale, scale_quadratic, scale_cubic : (3,) array_like
        ``k1``, ``k2``, ``k3`` per axis (SI per raw unit, per raw unit², per raw unit³).
    bias : (3,) array_like
        ``b`` in raw units.
    g_sensitivity : (3, 3) array_like
        ``G`` in raw units per m/s² (gyroscope; zero for accelerometers).
    shape : {"upper", "full", "lower"}
        Which misalignment entries are free.
    output_bias : (3,) array_like
        ``d``, a bias added after the scale polynomial, in calibrated units:
        ``T · (f(u − b − G a) + d)``. Zero in the canonical model; it represents
        Wang 2019's ``C (K1 N + K2 N² + K3 N³ + ∇)`` (eq. 2) exactly, which an
        input-side ``b`` cannot once ``k2``/``k3`` ≠ 0.

    Raises
    ------
    ValueError
        For entries of the wrong shape, a misalignment whose diagonal is not 1 or with entries outside
        ``shape``, or a zero scale factor.

    Examples
    --------
    An accelerometer with 0.01 m/s² per count and a bias of 10 counts on x: raw readings to SI and back:

    >>> import numpy as np
    >>> from imucalib.models import TriadModel
    >>> model = TriadModel(scale=[0.01, 0.01, 0.01], bias=[10, 0, 0])
    >>> model.forward(np.array([[110.0, 0.0, 981.0]]))
    array([[1.  , 0.  , 9.81]])
    >>> model.inverse(np.array([[1.0, 0.0, 9.81]]))
    array([[110.,   0., 981.]])
    """

    misalignment: np.ndarray = field(default_factory=lambda: np.eye(3))
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    scale_quadratic: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale_cubic: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    g_sensitivity: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    shape: str = "full"
    output_bias: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def __post_init__(self) -> None:
        # every array converted, then every condition checked at once; on any fault the checks one by one
        # (_validate) raise the error that names it
        as_float = np.array
        t = as_float(self.misalignment, dtype=np.float64)
        vecs = [as_float(getattr(self, name), dtype=np.float64).reshape(-1) for name in _VECTORS[:4]]
        g = as_float(self.g_sensitivity, dtype=np.float64)
        d = as_float(self.output_bias, dtype=np.float64).reshape(-1)
        fixed = _FIXED.get(self.shape)
        if (fixed is not None and t.shape == g.shape == (3, 3) and d.shape == (3,)
                and all(v.shape == (3,) for v in vecs)
                and np.isfinite(np.concatenate((t.reshape(-1), g.reshape(-1), d, *vecs))).all()
                and (np.abs(t.diagonal() - 1.0) <= 1e-12).all()  # finite t: np.allclose(·, 1, rtol=0, atol=1e-12)
                and not t[fixed].any() and vecs[0].all()):
            set_ = object.__setattr__
            set_(self, "misalignment", t)
            for name, v in zip(_VECTORS[:4], vecs, strict=True):
                set_(self, name, v)
            set_(self, "g_sensitivity", g)
            set_(self, "output_bias", d)
            return
        self._validate()

    def _validate(self) -> None:
        """The checks of a new model one by one: raise the first fault's ValueError (else set the arrays)."""
        set_ = object.__setattr__
        t = _mat(self.misalignment, "misalignment")
        free = misalignment_entries(self.shape)
        if not (np.abs(t.diagonal() - 1.0) <= 1e-12).all():  # t is finite: np.allclose(·, 1, rtol=0, atol=1e-12)
            raise ValueError(f"misalignment must have a unit diagonal; got {np.diag(t)}")
        if t[_FIXED[self.shape]].any():
            raise ValueError(
                f"misalignment of shape {self.shape!r} may only have entries "
                f"{', '.join(AXES[i] + AXES[j] for i, j in free)} off the diagonal"
            )
        set_(self, "misalignment", t)
        for name in ("scale", "scale_quadratic", "scale_cubic", "bias"):
            set_(self, name, _vec(getattr(self, name), name))
        if not self.scale.all():
            raise ValueError(f"scale (k1) must be non-zero on every axis; got {self.scale}")
        set_(self, "g_sensitivity", _mat(self.g_sensitivity, "g_sensitivity"))
        set_(self, "output_bias", _vec(self.output_bias, "output_bias"))

    # ------------------------------------------------------------ properties
    @property
    def is_linear(self) -> bool:
        return not (np.any(self.scale_quadratic) or np.any(self.scale_cubic))

    def with_(self, **changes) -> TriadModel:
        """A copy with some fields replaced."""
        return replace(self, **changes)

    # --------------------------------------------------------------- forward
    def polynomial(self, x: np.ndarray) -> np.ndarray:
        """``f(x)_i = k1_i x_i + k2_i x_i² + k3_i x_i³`` (Zhang 2021, eq. 2)."""
        return x * (self.scale + x * (self.scale_quadratic + x * self.scale_cubic))

    def polynomial_derivative(self, x: np.ndarray) -> np.ndarray:
        """``f'(x)_i = k1_i + 2 k2_i x_i + 3 k3_i x_i²``."""
        return self.scale + x * (2 * self.scale_quadratic + 3 * x * self.scale_cubic)

    def forward(self, raw: np.ndarray, specific_force: np.ndarray | None = None) -> np.ndarray:
        """Raw readings (N, 3) → SI (N, 3): ``T · f(u − b − G·a)``.

        ``specific_force`` is the calibrated accelerometer (N, 3) [m/s²] that
        the g-sensitivity multiplies; it is needed only when ``G`` is non-zero.
        """
        raw = np.asarray(raw, dtype=np.float64)
        g_sensitive = self.g_sensitivity.any()
        if g_sensitive:
            if specific_force is None:
                raise ValueError("this model has a g-sensitivity: pass specific_force [m/s²]")
            specific_force = np.asarray(specific_force, dtype=np.float64)
        if raw.ndim != 2 or raw.shape[0] < _AXIS_ROWS or raw.shape[1] != 3 or \
                (g_sensitive and specific_force.shape != raw.shape):
            x = raw - self.bias
            if g_sensitive:
                x = x - specific_force @ self.g_sensitivity.T
            return (self.polynomial(x) + self.output_bias) @ self.misalignment.T
        # the same operations on the same numbers, an axis to a row: each ufunc runs over one axis's contiguous
        # numbers instead of three at a time; the product with T is taken on the (N, 3) layout as above
        x = np.empty((3, raw.shape[0]))
        np.subtract(raw.T, self.bias[:, None], out=x)
        if g_sensitive:
            np.subtract(x, (specific_force @ self.g_sensitivity.T).T, out=x)
        f = x * self.scale_cubic[:, None]  # polynomial(x): x (k1 + x (k2 + x k3))
        f += self.scale_quadratic[:, None]
        f *= x
        f += self.scale[:, None]
        f *= x
        f += self.output_bias[:, None]
        y = x.reshape(-1).reshape(raw.shape)  # x's memory, no longer read, holds f in the (N, 3) layout
        np.copyto(y, f.T)
        return y @ self.misalignment.T

    # --------------------------------------------------------------- inverse
    def inverse(self, si: np.ndarray, specific_force: np.ndarray | None = None) -> np.ndarray:
        """SI (N, 3) → raw readings (N, 3), the exact inverse of :meth:`forward`.

        The polynomial is inverted per axis by Newton's method. Raises
        :class:`NotInvertibleError` when ``f`` is not monotonic over the range
        the requested values need (its derivative vanishes there).
        """
        si = np.asarray(si, dtype=np.float64)
        y = np.linalg.solve(self.misalignment, si.reshape(-1, 3).T).T.reshape(si.shape)
        y = y - self.output_bias
        x = self.invert_polynomial(y)
        raw = x + self.bias
        if np.any(self.g_sensitivity):
            if specific_force is None:
                raise ValueError("this model has a g-sensitivity: pass specific_force [m/s²]")
            raw = raw + np.asarray(specific_force, dtype=np.float64) @ self.g_sensitivity.T
        return raw

    def monotonic_range(self) -> np.ndarray:
        """Raw interval ``[x_lo, x_hi]`` (3, 2) around 0 where each axis's ``f`` is monotonic."""
        out = np.empty((3, 2))
        for i in range(3):
            k1, k2, k3 = self.scale[i], self.scale_quadratic[i], self.scale_cubic[i]
            roots = np.array([])
            if k2 or k3:
                with np.errstate(all="ignore"):  # a vanishing k2, k3 puts the roots beyond any float
                    try:
                        roots = np.roots([3 * k3, 2 * k2, k1])
                    except np.linalg.LinAlgError:
                        roots = np.array([])
            roots = roots[np.isfinite(roots)]
            roots = np.sort(roots[np.abs(roots.imag) <= 1e-12 * np.abs(roots.real)].real)
            neg, pos = roots[roots < 0], roots[roots > 0]
            out[i] = (neg[-1] if neg.size else -np.inf, pos[0] if pos.size else np.inf)
        return out

    def invert_polynomial(self, y: np.ndarray) -> np.ndarray:
        """Solve ``f(x) = y`` per axis on the monotonic branch through 0 (Newton).

        Raises :class:`NotInvertibleError` when a value lies outside the range
        ``f`` reaches monotonically (its derivative vanishes first).
        """
        y = np.asarray(y, dtype=np.float64)
        if self.is_linear:
            return y / self.scale
        rng = self.monotonic_range()
        reach = np.empty((3, 2))
        for i in range(3):
            ends = []
            for x_end in rng[i]:
                if np.isfinite(x_end):
                    k1, k2, k3 = self.scale[i], self.scale_quadratic[i], self.scale_cubic[i]
                    with np.errstate(over="ignore"):  # an end beyond float range: the branch is unbounded
                        ends.append(float(x_end * (k1 + x_end * (k2 + x_end * k3))))
                else:  # unbounded branch: the cubic (or linear) term decides the sign
                    lead = self.scale_cubic[i] if self.scale_cubic[i] else self.scale[i]
                    ends.append(np.sign(lead) * np.sign(x_end) * np.inf)
            reach[i] = sorted(ends)
        flat = y.reshape(-1, 3)
        for i, axis in enumerate(AXES):
            bad = (flat[:, i] < reach[i, 0]) | (flat[:, i] > reach[i, 1])
            if np.any(bad):
                k1, k2, k3 = self.scale[i], self.scale_quadratic[i], self.scale_cubic[i]
                raise NotInvertibleError(
                    f"the {axis}-axis scale polynomial f(x) = {k1:.6g}x + {k2:.6g}x² + {k3:.6g}x³ "
                    f"is not monotonic beyond the raw range [{rng[i, 0]:.6g}, {rng[i, 1]:.6g}] "
                    f"(its derivative vanishes there), so it only reaches [{reach[i, 0]:.6g}, "
                    f"{reach[i, 1]:.6g}]; {int(np.count_nonzero(bad))} values lie outside: the "
                    "model cannot be inverted there (reduce the range or the nonlinear terms)"
                )
        x = np.clip(y / self.scale, rng[:, 0], rng[:, 1])
        for _ in range(100):
            fx = self.polynomial(x) - y
            dfx = self.polynomial_derivative(x)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(dfx != 0, fx / dfx, 0.0)
            x_new = np.clip(x - step, rng[:, 0], rng[:, 1])
            done = np.all(np.abs(x_new - x) <= 1e-15 * np.maximum(np.abs(x_new), 1e-300))
            x = x_new
            if done:
                break
        err = np.abs(self.polynomial(x) - y)
        tol = 1e-12 * np.maximum(np.abs(y), 1e-300)
        if not np.all(err <= tol):
            raise NotInvertibleError(
                "the scale polynomial could not be inverted to 1e-12 for "
                f"{int(np.count_nonzero(err > tol))} values (Newton did not converge)"
            )
        return x

    # ------------------------------------------------------------ parameters
    def parameters(self, prefix: str) -> dict[str, float]:
        """All named parameters ``{prefix}.<key>.<component>`` → value."""
        out: dict[str, float] = {}
        for i, j in misalignment_entries(self.shape):
            out[f"{prefix}.misalignment.{AXES[i]}{AXES[j]}"] = float(self.misalignment[i, j])
        for key in ("scale", "scale_quadratic", "scale_cubic", "bias"):
            vec = getattr(self, key)
            for i, axis in enumerate(AXES):
                out[f"{prefix}.{key}.{axis}"] = float(vec[i])
        for i in range(3):
            for j in range(3):
                out[f"{prefix}.g_sensitivity.{AXES[i]}{AXES[j]}"] = float(self.g_sensitivity[i, j])
        if np.any(self.output_bias):
            for i, axis in enumerate(AXES):
                out[f"{prefix}.output_bias.{axis}"] = float(self.output_bias[i])
        return out

    def with_parameters(self, prefix: str, values: dict[str, float]) -> TriadModel:
        """A copy with the named parameters (those starting with ``prefix.``) set."""
        t = self.misalignment.copy()
        vecs = {k: getattr(self, k).copy()
                for k in ("scale", "scale_quadratic", "scale_cubic", "bias", "output_bias")}
        g = self.g_sensitivity.copy()
        free = set(misalignment_entries(self.shape))
        for name, value in values.items():
            parts = name.split(".")
            if len(parts) != 3 or parts[0] != prefix:
                continue
            _, key, comp = parts
            if key == "misalignment" or key == "g_sensitivity":
                if len(comp) != 2 or comp[0] not in AXES or comp[1] not in AXES:
                    raise ValueError(f"unknown parameter {name!r}: component must be like 'xy'")
                ij = (AXES.index(comp[0]), AXES.index(comp[1]))
                if key == "misalignment":
                    if ij not in free:
                        raise ValueError(
                            f"parameter {name!r} is not free in a misalignment of shape "
                            f"{self.shape!r}"
                        )
                    t[ij] = value
                else:
                    g[ij] = value
            elif key in vecs:
                if comp not in AXES:
                    raise ValueError(f"unknown parameter {name!r}: component must be x, y or z")
                vecs[key][AXES.index(comp)] = value
            else:
                raise ValueError(f"unknown parameter {name!r}")
        return replace(self, misalignment=t, g_sensitivity=g, **vecs)

    # ------------------------------------------------------------------- JSON
    def to_dict(self, gyroscope: bool) -> dict:
        d = {
            "misalignment_shape": self.shape,
            "misalignment": self.misalignment.tolist(),
            "scale": self.scale.tolist(),
            "scale_quadratic": self.scale_quadratic.tolist(),
            "scale_cubic": self.scale_cubic.tolist(),
            "bias": self.bias.tolist(),
        }
        if gyroscope:
            d["g_sensitivity"] = self.g_sensitivity.tolist()
        if np.any(self.output_bias):
            d["output_bias"] = self.output_bias.tolist()
        return d

    @classmethod
    def from_dict(cls, d: dict, *, default_shape: str) -> TriadModel:
        try:
            return cls(
                misalignment=d["misalignment"],
                scale=d["scale"],
                scale_quadratic=d.get("scale_quadratic", [0.0, 0.0, 0.0]),
                scale_cubic=d.get("scale_cubic", [0.0, 0.0, 0.0]),
                bias=d["bias"],
                g_sensitivity=d.get("g_sensitivity", np.zeros((3, 3))),
                shape=d.get("misalignment_shape", default_shape),
                output_bias=d.get("output_bias", [0.0, 0.0, 0.0]),
            )
        except KeyError as exc:
            raise ValueError(f"calibration entry lacks the key {exc.args[0]!r}") from None


_SYMMETRIC = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))


@dataclass(frozen=True)
class MagnetometerModel:
    """Hard and soft iron and the map into the accelerometer's frame: ``m = F · O · S · (u − b)``.

    Attributes
    ----------
    bias : (3,) ndarray
        Hard-iron bias ``b`` [raw units].
    soft_iron : (3, 3) ndarray
        Symmetric positive definite ``S``: ``‖S (u − b)‖ = 1`` in a uniform field.
    alignment : (3, 3) ndarray
        Orthogonal ``O`` (determinant +1 or −1) from the sphere's frame to the accelerometer's.
    field_norm : float
        Field magnitude ``F`` in ``unit`` (1 when ``unit`` is ``"normalised"``).
    unit : str
        Calibrated unit, ``"uT"`` or ``"normalised"``.

    Examples
    --------
    A magnetometer with a hard-iron bias and no soft iron: the calibrated field is the reading less the bias,
    in units of the field's magnitude:

    >>> import numpy as np
    >>> from imucalib.models import MagnetometerModel
    >>> model = MagnetometerModel(bias=[10.0, -5.0, 3.0])
    >>> model.forward(np.array([[11.0, -5.0, 3.0]])), model.unit
    (array([[1., 0., 0.]]), 'normalised')
    """

    bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    soft_iron: np.ndarray = field(default_factory=lambda: np.eye(3))
    alignment: np.ndarray = field(default_factory=lambda: np.eye(3))
    field_norm: float = 1.0
    unit: str = "normalised"

    def __post_init__(self) -> None:
        object.__setattr__(self, "bias", _vec(self.bias, "magnetometer bias"))
        s = _mat(self.soft_iron, "soft_iron")
        o = _mat(self.alignment, "alignment")
        if not np.allclose(s, s.T, rtol=0, atol=1e-12 * max(np.abs(s).max(), 1e-300)):
            raise ValueError("the magnetometer's soft_iron matrix must be symmetric")
        if np.any(np.linalg.eigvalsh(s) <= 0):
            raise ValueError("the magnetometer's soft_iron matrix must be positive definite")
        if not np.allclose(o @ o.T, np.eye(3), atol=1e-9):
            raise ValueError("the magnetometer's alignment matrix must be orthogonal (OᵀO = I)")
        object.__setattr__(self, "soft_iron", 0.5 * (s + s.T))
        object.__setattr__(self, "alignment", o)
        if not (np.isfinite(self.field_norm) and self.field_norm > 0):
            raise ValueError(f"the magnetometer's field must be a positive number; got {self.field_norm!r}")
        object.__setattr__(self, "field_norm", float(self.field_norm))
        if self.unit not in ("uT", "normalised"):
            raise ValueError(f"the magnetometer's calibrated unit must be 'uT' or 'normalised'; got {self.unit!r}")

    @property
    def matrix(self) -> np.ndarray:
        """``F · O · S``: calibrated field per raw unit, after the bias."""
        return self.field_norm * self.alignment @ self.soft_iron

    def forward(self, raw: np.ndarray) -> np.ndarray:
        """Calibrated field (N, 3) in the accelerometer's frame from raw readings (N, 3)."""
        return (np.asarray(raw, dtype=np.float64) - self.bias) @ self.matrix.T

    def inverse(self, m: np.ndarray) -> np.ndarray:
        """Raw readings that give the calibrated field ``m`` (N, 3)."""
        return np.linalg.solve(self.matrix, np.asarray(m, dtype=np.float64).T).T + self.bias

    def axes(self) -> tuple[list[str], float]:
        """The signed axis permutation nearest ``O`` and the angle [deg] of the rotation left beside it.

        ``(["+y", "+x", "-z"], 1.2)`` reads: the accelerometer's x is the magnetometer's +y, its y
        the magnetometer's +x, its z the magnetometer's −z, then a 1.2° rotation.
        """
        o = self.alignment
        perm = np.zeros((3, 3))
        used: set[int] = set()
        for i in np.argsort(-np.abs(o).max(axis=1)):  # the clearest rows first
            j = max((c for c in range(3) if c not in used), key=lambda c: abs(o[i, c]))
            used.add(j)
            perm[i, j] = np.sign(o[i, j]) or 1.0
        rest = perm.T @ o
        if np.linalg.det(rest) < 0:  # not near a signed permutation with O's handedness
            angle = float("nan")
        else:
            angle = float(np.degrees(np.arccos(np.clip((np.trace(rest) - 1) / 2, -1.0, 1.0))))
        names = [("+" if perm[i, j] > 0 else "-") + AXES[j] for i in range(3) for j in range(3) if perm[i, j]]
        return names, angle

    def parameters(self, prefix: str = "magnetometer") -> dict[str, float]:
        """Named parameters ``magnetometer.bias.x``, ``.soft_iron.xy``, ``.alignment.xy``, ``.field``."""
        out = {f"{prefix}.bias.{a}": float(v) for a, v in zip(AXES, self.bias, strict=True)}
        for i, j in _SYMMETRIC:
            out[f"{prefix}.soft_iron.{AXES[i]}{AXES[j]}"] = float(self.soft_iron[i, j])
        for i in range(3):
            for j in range(3):
                out[f"{prefix}.alignment.{AXES[i]}{AXES[j]}"] = float(self.alignment[i, j])
        out[f"{prefix}.field"] = self.field_norm
        return out

    def to_dict(self) -> dict:
        names, angle = self.axes()
        return {"bias": self.bias.tolist(), "soft_iron": self.soft_iron.tolist(),
                "alignment": self.alignment.tolist(), "field": self.field_norm, "unit": self.unit,
                "axes": names, "alignment_rotation_deg": angle if np.isfinite(angle) else None,
                "matrix": self.matrix.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> MagnetometerModel:
        if not isinstance(d, dict):
            raise ValueError("the magnetometer section must be an object with bias, soft_iron and alignment")
        try:
            return cls(bias=d["bias"], soft_iron=d["soft_iron"], alignment=d["alignment"],
                       field_norm=d.get("field", 1.0), unit=d.get("unit", "normalised"))
        except KeyError as exc:
            raise ValueError(f"the magnetometer section lacks the key {exc.args[0]!r}") from None
