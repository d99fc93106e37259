"""pbrt-v4's own coateddiffuse estimator, ported line by line, against the export.

``layered_f`` follows ``LayeredBxDF<DielectricBxDF, DiffuseBxDF, true>::f``
(src/pbrt/bxdfs.h) with ``albedo = 0`` and ``nSamples = 1``, vectorised over
samples; ``Dielectric`` follows ``DielectricBxDF::Sample_f / f / PDF``
(src/pbrt/bxdfs.cpp) and ``TrowbridgeReitzDistribution`` (util/scattering.h). Its
mean is what pbrt renders; the export's closed form (pbrt_layer, ``T'``) must agree
with it, and the layered model's (``T``) must not, where pbrt's MIS weights matter.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdffit.data.geometry import Geometry, directions_from_angles
from brdffit.export.pbrt_layer import coated_brdf

N_SAMPLES = 150_000
SIGMAS = 4.0


def dot(a, b):
    return np.sum(a * b, axis=-1)


def unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def lam(w, a):
    z2 = w[..., 2] ** 2
    return (np.sqrt(1 + a * a * (1 - z2) / z2) - 1) / 2


def d_tr(m, a):
    c2 = m[..., 2] ** 2
    return 1 / (math.pi * a * a * c2 * c2 * (1 + (1 - c2) / (c2 * a * a)) ** 2)


def d_visible(w, m, a):
    """``D(w, wm) = G1(w) / |cos w| D(wm) |w.wm|``."""
    return d_tr(m, a) * np.abs(dot(w, m)) / (np.abs(w[:, 2]) * (1 + lam(w, a)))


def sample_wm(w, u, a):
    """``TrowbridgeReitzDistribution::Sample_wm``."""
    wh = unit(np.stack([a * w[:, 0], a * w[:, 1], w[:, 2]], -1))
    wh = np.where(wh[:, 2:] < 0, -wh, wh)
    t1 = np.cross(np.array([0.0, 0.0, 1.0]), wh)
    flat = wh[:, 2] >= 0.99999
    t1 = np.where(
        flat[:, None],
        [1.0, 0.0, 0.0],
        t1 / np.where(flat, 1, 1e-300 + np.linalg.norm(t1, axis=-1))[:, None],
    )
    t2 = np.cross(wh, t1)
    r, phi = np.sqrt(u[:, 0]), 2 * math.pi * u[:, 1]  # SampleUniformDiskPolar
    px, py = r * np.cos(phi), r * np.sin(phi)
    s = (1 + wh[:, 2]) / 2
    py = (1 - s) * np.sqrt(1 - px * px) + s * py
    pz = np.sqrt(np.maximum(0, 1 - px * px - py * py))
    nh = px[:, None] * t1 + py[:, None] * t2 + pz[:, None] * wh
    return unit(np.stack([a * nh[:, 0], a * nh[:, 1], np.maximum(1e-6, nh[:, 2])], -1))


def fr_dielectric(c, eta):
    c = np.clip(c, -1, 1)
    eta = np.where(c < 0, 1 / eta, eta)
    c = np.abs(c)
    s2 = (1 - c * c) / eta**2
    ct = np.sqrt(np.maximum(0, 1 - s2))
    r_parl = (eta * c - ct) / (eta * c + ct)
    r_perp = (c - eta * ct) / (c + eta * ct)
    return np.where(s2 >= 1, 1.0, (r_parl**2 + r_perp**2) / 2)


def refract(wi, n, eta):
    """pbrt's ``Refract``: (valid, wt, etap)."""
    c = dot(n, wi)
    flip = c < 0
    eta = np.where(flip, 1 / eta, eta)
    c, n = np.abs(c), np.where(flip[:, None], -n, n)
    s2 = np.maximum(0, 1 - c * c) / eta**2
    ct = np.sqrt(np.maximum(0, 1 - s2))
    return s2 < 1, -wi / eta[:, None] + (c / eta - ct)[:, None] * n, eta


class Dielectric:
    """``DielectricBxDF`` (rough): Sample_f with reflection or transmission only, f, PDF."""

    def __init__(self, eta, a):
        self.eta, self.a = eta, a

    def sample(self, wo, rng, radiance, transmission):
        a, n = self.a, len(wo)
        wm = sample_wm(wo, rng.random((n, 2)), a)
        r = fr_dielectric(dot(wo, wm), self.eta)
        if not transmission:  # pr = R, pt = 0: reflection, pdf without pr / (pr + pt)
            wi = -wo + 2 * dot(wo, wm)[:, None] * wm
            ok = wi[:, 2] * wo[:, 2] > 0
            pdf = d_visible(wo, wm, a) / (4 * np.abs(dot(wo, wm)))
            f = d_tr(wm, a) * r / (1 + lam(wo, a) + lam(wi, a)) / (4 * wi[:, 2] * wo[:, 2])
        else:
            ok, wi, etap = refract(wo, wm, np.full(n, self.eta))
            ok &= (wi[:, 2] * wo[:, 2] < 0) & (wi[:, 2] != 0)
            denom = (dot(wi, wm) + dot(wo, wm) / etap) ** 2
            pdf = d_visible(wo, wm, a) * np.abs(dot(wi, wm)) / denom
            g = 1 / (1 + lam(wo, a) + lam(wi, a))
            f = (
                (1 - r)
                * d_tr(wm, a)
                * g
                * np.abs(dot(wi, wm) * dot(wo, wm) / (wi[:, 2] * wo[:, 2] * denom))
            )
            f = f / etap**2 if radiance else f
        ok &= (f > 0) & (pdf > 0)
        return ok, np.where(ok, f, 0.0), wi, np.where(ok, pdf, 1.0)

    def _half(self, wo, wi):
        reflect = wi[:, 2] * wo[:, 2] > 0
        etap = np.where(reflect, 1.0, np.where(wo[:, 2] > 0, self.eta, 1 / self.eta))
        wm = unit(wi * etap[:, None] + wo)
        wm = np.where(wm[:, 2:] < 0, -wm, wm)
        ok = (dot(wm, wi) * wi[:, 2] >= 0) & (dot(wm, wo) * wo[:, 2] >= 0)
        return reflect, etap, wm, ok

    def f_transmission(self, wo, wi):
        """``f(wo, wi, Radiance)`` for wo, wi on opposite sides."""
        _, etap, wm, ok = self._half(wo, wi)
        a, f = self.a, fr_dielectric(dot(wo, wm), self.eta)
        denom = (dot(wi, wm) + dot(wo, wm) / etap) ** 2 * wi[:, 2] * wo[:, 2]
        g = 1 / (1 + lam(wo, a) + lam(wi, a))
        ft = d_tr(wm, a) * (1 - f) * g * np.abs(dot(wi, wm) * dot(wo, wm) / denom) / etap**2
        return np.where(ok, ft, 0.0)

    def f_reflection(self, wo, wi):
        _, _, wm, ok = self._half(wo, wi)
        a, f = self.a, fr_dielectric(dot(wo, wm), self.eta)
        g = 1 / (1 + lam(wo, a) + lam(wi, a))
        return np.where(ok, d_tr(wm, a) * g * f / np.abs(4 * wi[:, 2] * wo[:, 2]), 0.0)

    def pdf_transmission(self, wo, wi):
        """``PDF(wo, wi, mode, Transmission)``."""
        _, etap, wm, ok = self._half(wo, wi)
        denom = (dot(wi, wm) + dot(wo, wm) / etap) ** 2
        return np.where(ok, d_visible(wo, wm, self.a) * np.abs(dot(wi, wm)) / denom, 0.0)


def power(f, g):
    return f * f / (f * f + g * g)


def layered_f(wo, wi, reflectance, a, eta, thickness, maxdepth, n, seed):
    """Samples of ``LayeredBxDF::f(wo, wi, Radiance)`` for coateddiffuse (shape (n,))."""
    rng, top = np.random.default_rng(seed), Dielectric(eta, a)
    wo, wi = np.tile(wo, (n, 1)), np.tile(wi, (n, 1))
    tr = lambda w: np.exp(-np.abs(thickness / w[:, 2]))  # noqa: E731
    f = top.f_reflection(wo, wi)
    ok, f_os, w, pdf_os = top.sample(wo, rng, radiance=True, transmission=True)
    ok_is, f_is, w_is, pdf_is = top.sample(wi, rng, radiance=False, transmission=True)
    alive = ok & ok_is  # either failing: `continue`, the whole sample skipped
    beta = np.where(alive, f_os * np.abs(w[:, 2]) / pdf_os, 0.0)
    for depth in range(maxdepth):
        if depth > 3:  # Russian roulette
            q = np.maximum(0, 1 - beta)
            roulette = beta < 0.25
            alive &= ~(roulette & (rng.random(n) < q))
            beta = np.where(roulette & alive, beta / np.where(q < 1, 1 - q, 1), beta)
        beta = np.where(alive, beta * tr(w), 0.0)
        if depth % 2:  # z == exitZ: reflection at the interface, from inside
            ok, f_r, w_r, pdf_r = top.sample(-w, rng, radiance=True, transmission=False)
            alive &= ok
            beta = np.where(alive, beta * f_r * np.abs(w_r[:, 2]) / pdf_r, 0.0)
            w = np.where(alive[:, None], w_r, w)
            continue
        # The base: NEE along wis, then the cosine sample and its exit through the top.
        weight = power(pdf_is, np.abs(w_is[:, 2]) / math.pi)
        f += beta * reflectance / math.pi * np.abs(w_is[:, 2]) * weight * tr(w_is) * f_is / pdf_is
        r, phi = np.sqrt(rng.random(n)), 2 * math.pi * rng.random(n)
        w = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - r * r)], -1)
        beta = beta * reflectance
        exit_pdf = top.pdf_transmission(-w, wi)  # pbrt's: PDF(-w -> wi)
        weight = power(w[:, 2] / math.pi, exit_pdf)
        f += beta * tr(w) * top.f_transmission(-w, wi) * weight
    return f


CASES = [  # alpha, eta, thickness, R
    (0.3, 1.5, 0.01, 0.8),
    (0.5, 2.2, 0.05, 0.9),
]


@pytest.mark.parametrize("case", CASES)
def test_pbrt_estimator_converges_to_the_export(case):
    a, eta, thickness, big_r = case
    q = {"reflectance": [big_r], "uroughness": a, "vroughness": a, "eta": eta,
         "thickness": thickness, "maxdepth": 10}  # fmt: skip
    far = []
    for k, (theta_i, theta_o) in enumerate(((0.0, 30.0), (40.0, 60.0), (75.0, 15.0))):
        wi = directions_from_angles([theta_i], [30.0])
        wo = directions_from_angles([theta_o], [200.0])
        samples = layered_f(wo[0], wi[0], big_r, a, eta, thickness, 10, N_SAMPLES, k)
        mean, se = samples.mean(), samples.std() / math.sqrt(N_SAMPLES)
        pbrt = coated_brdf(Geometry(wi, wo), q)[0, 0]
        layered = coated_brdf(Geometry(wi, wo), q, mis=False)[0, 0]
        assert se < 0.005 * mean
        assert abs(pbrt - mean) < SIGMAS * se, (case, theta_i, pbrt, mean, se)
        far.append(abs(layered - mean) / se)
    assert max(far) > 20  # pbrt's MIS weights matter: the layered model is not pbrt
