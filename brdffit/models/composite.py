"""Sums of lobes as models: ``lambert+cook_torrance+cook_torrance``.

Measured materials are often fitted by a diffuse term plus two specular lobes
(a sharp one and a broad one). A sum of registered models is itself a model:
its design concatenates the components' columns and adds their offsets, so the
fitting engine needs nothing special for it.

Naming. Each parameter is ``<component>.<param>``, where ``<component>`` is the
model name, suffixed ``_1``, ``_2``... when a model occurs more than once:
``lambert.kd``, ``cook_torrance_1.ks``, ``cook_torrance_1.m``,
``cook_torrance_2.ks``...

Order of repeated lobes. A sum with two lobes of the same model is unchanged
when the lobes swap; fitted parameters are reported in one canonical order:
repeated lobes sorted by their first shape parameter, ascending (for
``cook_torrance`` the sharper lobe, smaller ``m``, comes first; for ``blinn``
the broader one, smaller ``n``).

Diffuse terms. Several Lambertian terms (the ``kd / pi`` of each component)
are the same column, so their ``kd`` could not be told apart: only the first
component's constant column is kept, and the constant-column parameters of the
later components are removed from the sum (held at 0).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace

import numpy as np

from ..data.geometry import Geometry
from ..errors import ModelError
from .base import Classification, Design, Model

__all__ = ["component_labels", "sum_of_lobes"]


def component_labels(names: list[str]) -> list[str]:
    """``[a, b, b]`` -> ``[a, b_1, b_2]``."""
    counts = {n: names.count(n) for n in names}
    seen: dict[str, int] = {}
    labels = []
    for n in names:
        if counts[n] == 1:
            labels.append(n)
        else:
            seen[n] = seen.get(n, 0) + 1
            labels.append(f"{n}_{seen[n]}")
    return labels


def _constant_columns(model: Model) -> set[str]:
    """Coefficients whose column is a constant (a Lambertian term)."""
    probe = Geometry(np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]]), check=False)
    shape = {p.name: p.default for p in model.shape_params}
    design = model.design(probe, shape)
    return {name for name, col in zip(model.coefficients, design.columns) if np.ndim(col) == 0}


def _is_diffuse(name: str, group: list, dropped: list) -> bool:
    """A parameter dropped from any lobe of a group is the group's shared diffuse term."""
    return any(name in dropped[i] for i in group)


def _combined_classification(models) -> Classification:
    cls = [m.classification for m in models]
    return Classification(
        origin="physical" if all(c.origin == "physical" for c in cls) else "empirical",
        symmetry="anisotropic" if any(c.symmetry == "anisotropic" for c in cls) else "isotropic",
        operand="angle" if any(c.operand == "angle" for c in cls) else "cosine",
        highlight="material" if any(c.highlight == "material" for c in cls) else "light",
        wave_optics=any(c.wave_optics for c in cls),
    )


def _coefficient_limits(models, dropped) -> dict:
    """The sum's ``coefficient_bounds`` and ``coefficient_constraints``: each component's own
    (:attr:`Model.coefficient_ranges`, :attr:`Model.coefficient_constraints`),
    placed at its coefficients' positions in the sum (removed ones are held at 0)."""
    bounds, rows = [], []
    start = 0
    total = sum(len([c for c in m.coefficients if c not in d]) for m, d in zip(models, dropped))
    for model, drop in zip(models, dropped):
        kept = [i for i, name in enumerate(model.coefficients) if name not in drop]
        ranges = model.coefficient_ranges
        bounds += [ranges[i] for i in kept]
        for row, bound in model.coefficient_constraints or ():
            full = [0.0] * total
            for j, i in enumerate(kept):
                full[start + j] = float(row[i])
            rows.append((tuple(full), bound))
        start += len(kept)
    return {"coefficient_bounds": tuple(bounds), "coefficient_constraints": tuple(rows) or None}


def _dropped_columns(models: list[Model]) -> list[set[str]]:
    """Per component, the constant (diffuse) columns it gives up: only the first
    diffuse term of a sum is kept, the others would be the same column again."""
    dropped: list[set[str]] = []
    have_constant = False
    for model in models:
        const = _constant_columns(model)
        drop = set(const) if have_constant else set()
        have_constant = have_constant or bool(const)
        if drop and model.to_coefficients is not None:
            raise ModelError(f"{model.name} cannot be summed after another diffuse term", "model")
        dropped.append(drop)
    return dropped


class _Sum:
    """The functions a sum of lobes hands to :class:`Model`: each component's
    parameters live under its label (``ggx``, ``ggx_2``...), minus its dropped columns."""

    def __init__(self, models: list[Model]):
        self.models = models
        self.labels = component_labels([m.name for m in models])
        self.dropped = _dropped_columns(models)

    def params(self) -> tuple:
        linear, shape = [], []
        for model, label, drop in zip(self.models, self.labels, self.dropped):
            for p in model.params:
                if p.name not in drop:
                    (linear if p.linear else shape).append(replace(p, name=f"{label}.{p.name}"))
        return tuple(linear + shape)

    def coefficients(self) -> tuple:
        return tuple(
            f"{label}.{c}"
            for model, label, drop in zip(self.models, self.labels, self.dropped)
            for c in model.coefficients
            if c not in drop
        )

    def split(self, values: Mapping, i: int, held: bool = True) -> dict:
        """Component i's own values; with ``held``, its removed params at 0."""
        prefix = self.labels[i] + "."
        sub = {k[len(prefix) :]: v for k, v in values.items() if k.startswith(prefix)}
        if held:
            sub.update({name: 0.0 for name in self.dropped[i]})
        return sub

    def design(self, geometry: Geometry, shape_values: Mapping) -> Design:
        columns, offset = [], None
        for i, model in enumerate(self.models):
            d = model.design(geometry, self.split(shape_values, i, held=False))
            kept = [c for c, n in zip(d.columns, model.coefficients) if n not in self.dropped[i]]
            columns += kept
            if d.offset is not None:
                offset = d.offset if offset is None else offset + d.offset
        return Design(tuple(columns), offset)

    def to_coefficients(self, values: Mapping) -> list:
        out = []
        for i, model in enumerate(self.models):
            coefs = model.coefficient_values(self.split(values, i))
            out += [c for c, n in zip(coefs, model.coefficients) if n not in self.dropped[i]]
        return out

    def from_coefficients(self, coefs: Mapping) -> dict:
        out = {}
        for i, model in enumerate(self.models):
            params = model.params_from_coefficients(self.split(coefs, i))
            label, drop = self.labels[i], self.dropped[i]
            out.update({f"{label}.{k}": v for k, v in params.items() if k not in drop})
        return out

    def canonical(self, values: Mapping) -> dict:
        """Repeated lobes of one model ordered by their first shape parameter."""
        out = dict(values)
        groups: dict[str, list[int]] = {}
        for i, model in enumerate(self.models):
            groups.setdefault(model.name, []).append(i)
        for idx in groups.values():
            first = self.models[idx[0]].shape_params
            if len(idx) < 2 or not first:
                continue
            key = first[0].name
            order = sorted(idx, key=lambda i: float(values[f"{self.labels[i]}.{key}"]))
            for dst, src in zip(idx, order):
                self._move(out, values, idx, dst, src)
        return out

    def _move(self, out: dict, values: Mapping, idx: list, dst: int, src: int) -> None:
        skip = self.dropped[dst] | self.dropped[src]
        for p in self.models[dst].params:
            # The Lambertian term kept by the first lobe belongs to the sum,
            # not to a lobe: it does not move with the lobes.
            if p.name not in skip and not _is_diffuse(p.name, idx, self.dropped):
                out[f"{self.labels[dst]}.{p.name}"] = values[f"{self.labels[src]}.{p.name}"]


def sum_of_lobes(models: list[Model]) -> Model:
    """A model that is the sum of ``models`` (see the module docstring)."""
    if len(models) < 2:
        raise ModelError("a sum of lobes needs at least two models", "model")
    parts = _Sum(models)
    doc = "Sum of lobes: " + " + ".join(
        f"{label} ({m.name}: {m.doc.strip().splitlines()[0]})"
        for label, m in zip(parts.labels, models)
    )
    return Model(
        name="+".join(m.name for m in models),
        params=parts.params(),
        classification=_combined_classification(models),
        reference="; ".join(dict.fromkeys(m.reference for m in models)),
        design=parts.design,
        doc=doc,
        coefficients=parts.coefficients(),
        to_coefficients=parts.to_coefficients,
        from_coefficients=parts.from_coefficients,
        reciprocal=all(m.reciprocal for m in models),
        canonical=parts.canonical,
        **_coefficient_limits(models, parts.dropped),
    )
