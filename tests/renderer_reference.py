"""The export tests' own evaluators of OpenPBR's and Blender's opaque BRDF.

Written from the published formulas, not from brdffit's code, and integrated
differently: OpenPBR Surface v1.1 (sections "Microfacet model" for GGX and the
anisotropy map, "Dielectric base", "Metal" for F82 tint, "Glossy-diffuse" and
"Layering" for ``f = f_spec + (1 - E_spec(omega_o)) f_diffuse``); Cycles'
Principled BSDF (intern/cycles/kernel/svm/closure.h: ``alpha_x = r^2 / sqrt(1 -
0.9 a)``, the tangent turned by ``2 pi`` x rotation, the diffuse weighted by
``1 - mix(F0, 1, s)`` where ``s`` is the Fresnel blend averaged over the lobe
and normalised by the lobe itself). Here:

- the dielectric Fresnel is Cook and Torrance's ``g``-form;
- ``D`` and ``Lambda`` are written with the micronormal's polar angles;
- ``E(omega_o)`` is a brute-force integral over half vectors, ``theta_h =
  atan(alpha tan x)`` on Gauss-Legendre nodes in ``x`` and equal steps in
  azimuth, with ``d omega_i = 4 (omega_o . h) d omega_h``;
- directional albedos integrate ``f cos`` over a plain grid of view directions.
"""

from __future__ import annotations

import math

import numpy as np

MU_82 = 1.0 / 7.0


def fresnel(c, eta):
    """Cook-Torrance: ``1/2 (g-c)^2/(g+c)^2 (1 + ((c(g+c) - 1)/(c(g-c) + 1))^2)``."""
    c = np.asarray(c, dtype=float)
    g = np.sqrt(eta * eta - 1.0 + c * c)
    a = (g - c) ** 2 / (g + c) ** 2
    b = ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)) ** 2
    return 0.5 * a * (1.0 + b)


def schlick(mu, f0):
    return f0 + (1.0 - f0) * (1.0 - mu) ** 5


def f82_tint(mu, f0, tint):
    """OpenPBR "Metal": ``F_s(mu) - mu (1-mu)^6 / (mu_b (1-mu_b)^6) (F_s(mu_b) - F(mu_b))``."""
    edge = schlick(MU_82, f0)
    return schlick(mu, f0) - mu * (1 - mu) ** 6 / (MU_82 * (1 - MU_82) ** 6) * (edge - tint * edge)


class Lobe:
    """GGX with height-correlated Smith, alphas along the tangent turned by ``rotation``."""

    def __init__(self, alpha_t, alpha_b, rotation=0.0):
        self.at, self.ab = alpha_t, alpha_b
        self.t = np.array([math.cos(rotation), math.sin(rotation), 0.0])
        self.b = np.array([-math.sin(rotation), math.cos(rotation), 0.0])

    def _angles(self, w):
        x, y, z = w @ self.t, w @ self.b, w[..., 2]
        return np.arctan2(y, x), (x * x + y * y) / (z * z)

    def ndf(self, h):
        phi, tan2 = self._angles(h)
        cos4 = h[..., 2] ** 4
        k = np.cos(phi) ** 2 / self.at**2 + np.sin(phi) ** 2 / self.ab**2
        return 1.0 / (math.pi * self.at * self.ab * cos4 * (1.0 + tan2 * k) ** 2)

    def smith_lambda(self, w):
        phi, tan2 = self._angles(w)
        a2 = np.cos(phi) ** 2 * self.at**2 + np.sin(phi) ** 2 * self.ab**2
        return (-1.0 + np.sqrt(1.0 + a2 * tan2)) / 2.0

    def spec(self, wi, wo):
        """``D G2 / (4 cos_i cos_o)`` and ``wi . h``."""
        h = wi + wo
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        g2 = 1.0 / (1.0 + self.smith_lambda(wi) + self.smith_lambda(wo))
        return self.ndf(h) * g2 / (4 * wi[..., 2] * wo[..., 2]), np.sum(wi * h, axis=-1)

    def view_albedos(self, views, eta, n=(160, 192)):
        """``(E_F, E_1)`` at each view (brute force over half vectors)."""
        x, wx = np.polynomial.legendre.leggauss(n[0])
        x, wx = (x + 1) * math.pi / 4, wx * math.pi / 4
        a = math.sqrt(self.at * self.ab)
        theta = np.arctan(a * np.tan(x))
        dtheta = a / np.cos(x) ** 2 / (1 + (a * np.tan(x)) ** 2) * wx
        phi = 2 * math.pi * (np.arange(n[1]) + 0.5) / n[1]
        tt, pp = np.meshgrid(theta, phi, indexing="ij")
        h = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
        h = h.reshape(-1, 3)
        dh = (np.sin(tt) * dtheta[:, None] * 2 * math.pi / n[1]).ravel()
        out = np.empty((len(views), 2))
        for k, v in enumerate(np.asarray(views, dtype=float)):
            vh = h @ v
            wi = 2 * vh[:, None] * h - v
            ok = (vh > 0) & (wi[:, 2] > 1e-12)
            s, c = self.spec(wi[ok], np.broadcast_to(v, wi[ok].shape))
            weight = s * wi[ok, 2] * 4 * vh[ok] * dh[ok]
            out[k] = (fresnel(c, eta) * weight).sum(), weight.sum()
        return out[:, 0], out[:, 1]


def _per_view(lobe, wo, eta):
    """``(E_F, E_1)`` at each ``wo``, computed once per distinct view."""
    if lobe.at == lobe.ab:  # isotropic: E depends on cos(theta_o) only
        unique, index = np.unique(np.round(wo[:, 2], 12), return_inverse=True)
        views = np.stack([np.sqrt(1 - unique**2), 0 * unique, unique], axis=1)
        e_f, e_1 = lobe.view_albedos(views, eta)
        return e_f[np.ravel(index)], e_1[np.ravel(index)]
    unique, index = np.unique(np.round(wo, 12), axis=0, return_inverse=True)
    e_f, e_1 = lobe.view_albedos(unique, eta)
    return e_f[np.ravel(index)], e_1[np.ravel(index)]


def openpbr(wi, wo, q):
    """OpenPBR's BRDF (N, 3) for the ``open_pbr_surface`` inputs ``q`` plus the
    tangent rotation ``q["rotation"]`` (radians)."""
    r, a = q["specular_roughness"], q.get("specular_roughness_anisotropy", 0.0)
    alpha_t = r * r * math.sqrt(2.0 / (1.0 + (1.0 - a) ** 2))
    lobe = Lobe(alpha_t, (1.0 - a) * alpha_t, q.get("rotation", 0.0))
    base = np.asarray(q["base_weight"]) * np.asarray(q["base_color"])
    tint, eta, m = np.asarray(q["specular_color"]), q["specular_ior"], q["base_metalness"]
    s, c = lobe.spec(wi, wo)
    e_f, _ = _per_view(lobe, wo, eta)
    metal = f82_tint(c[:, None], base, tint) * s[:, None]
    gloss = tint * fresnel(c, eta)[:, None] * s[:, None]
    diffuse = (1.0 - e_f)[:, None] * base / math.pi
    return m * metal + (1.0 - m) * (gloss + diffuse)


def blender(wi, wo, inputs):
    """Cycles' Principled BSDF (GGX, Specular Tint white, IOR Level 0.5), (N, 3)."""
    r, a = inputs["Roughness"], inputs.get("Anisotropic", 0.0)
    k = math.sqrt(1.0 - 0.9 * a)
    turn = 2 * math.pi * inputs.get("Anisotropic Rotation", 0.0)
    lobe = Lobe(r * r / k, r * r * k, turn)
    base, eta, m = np.asarray(inputs["Base Color"][:3]), inputs["IOR"], inputs["Metallic"]
    s, c = lobe.spec(wi, wo)
    e_f, e_1 = _per_view(lobe, wo, eta)
    metal = schlick(c[:, None], base) * s[:, None]
    gloss = fresnel(c, eta)[:, None] * s[:, None]
    diffuse = (1.0 - e_f / e_1)[:, None] * base / math.pi
    return m * metal + (1.0 - m) * (gloss + diffuse)


def albedo(brdf, params, theta_deg, n=(96, 192)):
    """``integral f(L, V) cos(theta_v) dw_v`` at ``L = (theta, phi = 0)`` on a
    Gauss-Legendre x equal-step grid of views (rough lobes only)."""
    t = math.radians(theta_deg)
    light = np.array([math.sin(t), 0.0, math.cos(t)])
    x, w = np.polynomial.legendre.leggauss(n[0])
    theta, w = (x + 1) * math.pi / 4, w * math.pi / 4
    phi = 2 * math.pi * (np.arange(n[1]) + 0.5) / n[1]
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    views = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1)
    views = views.reshape(-1, 3)
    dw = (np.sin(tt) * np.cos(tt) * w[:, None] * 2 * math.pi / n[1]).ravel()
    f = brdf(np.broadcast_to(light, views.shape), views, params)
    return dw @ f


def rms_log(f, y, cos_i):
    """RMS of ``ln(1 + f cos(theta_i)) - ln(1 + y cos(theta_i))`` (the issue's measure)."""
    d = np.log1p(np.maximum(f, 0) * cos_i[:, None]) - np.log1p(np.maximum(y, 0) * cos_i[:, None])
    return float(np.sqrt(np.mean(d * d)))
