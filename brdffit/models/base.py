"""What a model is: parameters, classification, and a design function.

Every model of brdffit is written as

    f(L, V) = offset(L, V; shape) + sum_j c_j * column_j(L, V; shape)

where the ``shape`` parameters enter non-linearly (exponents, roughness,
refractive index) and the coefficients ``c_j`` enter linearly (``kd``, ``ks``,
one value per colour channel). The model's *design function* returns the
offset and the columns for given shape parameters on a prepared
:class:`~brdffit.data.geometry.Geometry`; evaluation combines them with the
coefficients, and the fitting engine solves for the coefficients by
non-negative least squares instead of searching them (variable projection).

For almost every model the coefficients are the linear parameters themselves.
Where a "linear" parameter also enters non-linearly (Ashikhmin-Shirley's
``rs`` scales the diffuse term too), the model supplies ``to_coefficients``
and ``from_coefficients`` mapping its parameters to coefficients in which it is
linear; the docstring of such a model says how.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..data.geometry import Geometry
from ..errors import ParameterError

__all__ = ["Param", "Classification", "Design", "Model", "diffuse_plus_lobe", "INV_PI"]

INV_PI = 1.0 / math.pi

ORIGINS = ("empirical", "physical")
SYMMETRIES = ("isotropic", "anisotropic")
OPERANDS = ("cosine", "angle")
HIGHLIGHTS = ("light", "material")


@dataclass(frozen=True)
class Param:
    """One model parameter.

    ``log_scale`` parameters (spanning decades) are searched in log space;
    ``linear`` ones are solved for, per colour channel, rather than searched.
    ``per_channel`` ones are not linear but take one value per channel (the
    wavelength of each band in a wave-optics model); a fit takes them from the
    data rather than searching them.
    """

    name: str
    lower: float
    upper: float
    default: float
    log_scale: bool = False
    linear: bool = False
    unit: str = ""
    doc: str = ""
    per_channel: bool = False

    def __post_init__(self):
        if not (self.lower <= self.default <= self.upper):
            raise ValueError(f"default of {self.name} outside its bounds")
        if self.log_scale and self.lower <= 0:
            raise ValueError(f"log-scale parameter {self.name} needs a positive lower bound")

    def check(self, value) -> np.ndarray | float:
        """Return the value as a float (or a 1-D array for linear params), or raise."""
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"{self.name}={value!r} is not a number", self.name) from None
        several = self.linear or self.per_channel
        if arr.ndim > 1 or (arr.ndim == 1 and not several):
            need = "a number or one number per channel" if several else "a single number"
            raise ParameterError(
                f"{self.name} has shape {arr.shape}; it must be {need}", self.name
            )
        if arr.ndim == 1 and arr.size == 0:
            raise ParameterError(
                f"{self.name} is an empty list; give at least one value", self.name
            )
        if not np.isfinite(arr).all():
            raise ParameterError(f"{self.name}={value!r} is not finite", self.name)
        if (arr < self.lower).any() or (arr > self.upper).any():
            shown = float(arr) if arr.ndim == 0 else arr.tolist()
            raise ParameterError(
                f"{self.name}={shown} is outside its bounds ({self.lower:g}, {self.upper:g})",
                self.name,
            )
        return float(arr) if arr.ndim == 0 else arr

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "lower": self.lower,
            "upper": self.upper,
            "default": self.default,
            "log_scale": self.log_scale,
            "linear": self.linear,
            "unit": self.unit,
            "doc": self.doc,
            "per_channel": self.per_channel,
        }


@dataclass(frozen=True)
class Classification:
    """The axes of the classification paper (MODELS.md), as data."""

    origin: str
    symmetry: str
    operand: str
    highlight: str
    wave_optics: bool = False

    def __post_init__(self):
        for axis, allowed in (
            ("origin", ORIGINS),
            ("symmetry", SYMMETRIES),
            ("operand", OPERANDS),
            ("highlight", HIGHLIGHTS),
        ):
            if getattr(self, axis) not in allowed:
                raise ValueError(f"{axis} must be one of {allowed}")

    def to_dict(self) -> dict:
        return {
            "origin": self.origin,
            "symmetry": self.symmetry,
            "operand": self.operand,
            "highlight": self.highlight,
            "wave_optics": self.wave_optics,
        }


class Design(NamedTuple):
    """Columns scaled by the linear coefficients, and the part no coefficient scales.

    Each column is an array of shape (M,) over the valid pairs of a geometry, an
    array of shape (M, C) when it differs per channel (wavelength-dependent
    models), or a Python float for a constant column (such as Lambert's 1/pi).
    The offset is (M,), (M, C) or None.
    """

    columns: tuple
    offset: np.ndarray | None = None


DesignFn = Callable[[Geometry, Mapping[str, float]], Design]


@dataclass(frozen=True, eq=False)
class Model:
    """A reflectance model: parameters, classification and a design function.

    Attributes
    ----------
    name : str
        Registry name, as in MODELS.md.
    params : tuple of Param
        All parameters, linear ones first.
    classification : Classification
    reference : str
        The primary source of the formula.
    design : callable
        ``design(geometry, shape_params) -> Design``; see the module docstring.
    doc : str
        The formula and notes (numpydoc-style text).
    coefficients : tuple of str
        Names of the linear coefficients, in the order of the design's columns.
        Default: the linear parameters.
    reciprocal : bool
        Whether the formula obeys Helmholtz reciprocity exactly. Tests measure
        it; this flag says what they should find.
    held : tuple of str
        Parameters a fit holds at their defaults unless told to free them
        (material constants and instrument properties of wave-optics models).
    coefficient_bounds : tuple of (lower, upper), optional
        Bounds of each coefficient when they are not those of a parameter of the
        same name (mapped coefficients such as Ashikhmin-Shirley's ``rd_eff``).
    coefficient_constraints : tuple of (row, bound), optional
        Linear inequalities ``row . coefficients <= bound`` that the fitting
        engine enforces when it solves the coefficients.
    canonical : callable, optional
        ``canonical(params) -> params`` picks one of several equivalent parameter
        sets (the order of repeated lobes in a sum), so results are comparable.
    """

    name: str
    params: tuple
    classification: Classification
    reference: str
    design: DesignFn
    doc: str = ""
    coefficients: tuple = ()
    to_coefficients: Callable | None = None
    from_coefficients: Callable | None = None
    reciprocal: bool = True
    canonical: Callable | None = None
    held: tuple = ()
    coefficient_bounds: tuple | None = None
    coefficient_constraints: tuple | None = None
    _index: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        object.__setattr__(self, "_index", {p.name: p for p in self.params})
        if not self.coefficients:
            object.__setattr__(self, "coefficients", tuple(p.name for p in self.linear_params))
        object.__setattr__(self, "__doc__", self.doc)

    # ------------------------------------------------------------------ params
    @property
    def linear_params(self) -> tuple:
        return tuple(p for p in self.params if p.linear)

    @property
    def shape_params(self) -> tuple:
        return tuple(p for p in self.params if not p.linear)

    @property
    def param_names(self) -> tuple:
        return tuple(p.name for p in self.params)

    @property
    def coefficient_ranges(self) -> tuple:
        """Bounds ``(lower, upper)`` of each linear coefficient, in the order of
        :attr:`coefficients`: the declared :attr:`coefficient_bounds`, else those of
        the parameter of the same name, else ``(0, inf)``. What the fitting engine
        bounds the coefficients by."""
        if self.coefficient_bounds is not None:
            return tuple(tuple(b) for b in self.coefficient_bounds)
        found = [self._index.get(n) for n in self.coefficients]
        return tuple((p.lower, p.upper) if p is not None else (0.0, np.inf) for p in found)

    def param(self, name: str) -> Param:
        try:
            return self._index[name]
        except KeyError:
            raise ParameterError(
                f"{self.name} has no parameter {name!r}; its parameters are "
                f"{', '.join(self.param_names)}",
                name,
            ) from None

    def defaults(self) -> dict:
        return {p.name: p.default for p in self.params}

    def check_params(self, params: Mapping) -> dict:
        """Validate a full parameter mapping; return it with floats / 1-D arrays."""
        if not isinstance(params, Mapping):
            raise ParameterError(
                f"params must be a mapping of name to value, not {type(params).__name__}",
                "params",
            )
        unknown = [k for k in params if k not in self._index]
        if unknown:
            self.param(unknown[0])
        missing = [p.name for p in self.params if p.name not in params]
        if missing:
            raise ParameterError(f"{self.name} needs a value for {', '.join(missing)}", missing[0])
        checked = {p.name: p.check(params[p.name]) for p in self.params}
        several = [p for p in self.params if p.linear or p.per_channel]
        sizes = {np.size(checked[p.name]) for p in several} - {1}
        if len(sizes) > 1:
            raise ParameterError(
                "per-channel parameters must all have the same length, got "
                + ", ".join(f"{p.name}: {np.size(checked[p.name])}" for p in several),
                several[0].name,
            )
        return checked

    # -------------------------------------------------------------- evaluation
    def prepare(self, wi, wo) -> Geometry:
        """Check and prepare direction pairs once for repeated evaluation."""
        return Geometry(wi, wo)

    def evaluate(self, wi, wo, params: Mapping) -> np.ndarray:
        """BRDF values in 1/sr (not multiplied by a cosine).

        Returns shape (N,), or (N, C) when linear parameters are given per channel.
        """
        return self.evaluate_prepared(Geometry(wi, wo), params)

    def evaluate_prepared(self, geometry: Geometry, params: Mapping, check: bool = True):
        """Evaluate on a prepared :class:`Geometry`; only parameter-dependent work is done."""
        if check:
            params = self.check_params(params)
        shape = {p.name: params[p.name] for p in self.shape_params}
        coefs = self.coefficient_values(params)
        # A compiled design (brdffit.kernels) evaluates the whole BRDF in one pass.
        fused = getattr(self.design, "evaluate", None)
        values = fused(geometry, shape, coefs) if fused is not None else None
        if values is None:
            values = combine(self.design(geometry, shape), coefs, geometry.m)
        return geometry.scatter(values)

    def coefficient_values(self, params: Mapping) -> list:
        """The linear coefficients (floats or per-channel arrays) for given params."""
        if self.to_coefficients is not None:
            return list(self.to_coefficients(params))
        return [params[name] for name in self.coefficients]

    def params_from_coefficients(self, coefs: Mapping) -> dict:
        """Linear parameter values from solved coefficients (name -> value)."""
        if self.from_coefficients is not None:
            return dict(self.from_coefficients(coefs))
        return {name: coefs[name] for name in self.coefficients}

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "params": [p.to_dict() for p in self.params],
            "classification": self.classification.to_dict(),
            "reference": self.reference,
            "reciprocal": self.reciprocal,
            "doc": self.doc,
        }

    def __repr__(self) -> str:
        return f"Model({self.name!r})"


def combine(design: Design, coefs: Sequence, m: int) -> np.ndarray:
    """offset + sum_j c_j column_j, with c_j scalars or per-channel arrays."""
    two_d = [np.shape(a)[1] for a in (*design.columns, design.offset) if np.ndim(a) == 2]
    per_channel = bool(two_d) or any(np.ndim(c) == 1 for c in coefs)
    if per_channel:
        return _combine_channels(design, coefs, m, max([np.size(c) for c in coefs] + two_d))
    out, constant = None, 0.0
    for col, c in zip(design.columns, coefs):
        if np.ndim(col) == 0:
            constant += col * c
        elif out is None:
            out = col * c
        else:
            out += col * c
    if design.offset is not None:
        out = design.offset.copy() if out is None else out + design.offset
    if out is None:
        return np.full(m, constant)
    if constant:
        out += constant
    return out


def _combine_channels(design: Design, coefs: Sequence, m: int, n_ch: int) -> np.ndarray:
    """:func:`combine` per channel, (M, C): each array column times its coefficients
    once, constant columns summed into one row added last (fewer passes over memory)."""
    out, constant = None, np.zeros(n_ch)
    for col, c in zip(design.columns, (np.asarray(c, dtype=float) for c in coefs)):
        c = np.broadcast_to(c, (n_ch,)) if np.shape(c) != (n_ch,) else c  # 3 us less
        if np.ndim(col) == 0:
            constant += col * c
            continue
        term = col * c if np.ndim(col) == 2 else np.multiply.outer(col, c)
        out = term if out is None else np.add(out, term, out=out)
    if design.offset is not None:
        offset = design.offset if np.ndim(design.offset) == 2 else design.offset[:, None]
        out = np.broadcast_to(offset, (m, n_ch)) + 0.0 if out is None else out + offset
    if out is None:
        out = np.zeros((m, n_ch))
    if constant.any():
        out += constant
    return out


def diffuse_plus_lobe(
    name: str,
    lobe: Callable[..., np.ndarray],
    shape: Sequence[Param],
    classification: Classification,
    reference: str,
    doc: str,
    ks_upper: float = 1e4,
    reciprocal: bool = True,
) -> Model:
    """The common form ``kd / pi + ks * lobe(geometry, **shape)``."""
    params = (
        Param("kd", 0.0, 1.0, 0.5, linear=True, unit="1", doc="diffuse albedo"),
        Param("ks", 0.0, ks_upper, 1.0, linear=True, unit="1/sr", doc="specular scale"),
        *shape,
    )

    def design(geometry: Geometry, shape_values: Mapping[str, float]) -> Design:
        return Design((INV_PI, lobe(geometry, **shape_values)))

    return Model(
        name=name,
        params=params,
        classification=classification,
        reference=reference,
        design=design,
        doc=doc,
        reciprocal=reciprocal,
    )
