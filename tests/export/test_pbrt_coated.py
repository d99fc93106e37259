"""pbrt's coateddiffuse: the layered model's closed form against an independent walk.

(pbrt's own estimator converges elsewhere, see test_pbrt_layered.py; the closed form
of the layered model, ``mis=False``, is the one an unbiased walk converges to.)

The walk is a plain light tracer written here from the published formulas, not
pbrt's estimator: light arrives from ``wi``, meets a rough dielectric interface
(GGX normals drawn from ``D(m) cos(theta_m)``, Walter et al., Microfacet models for
refraction through rough surfaces, EGSR 2007, eqs. 35-36; exact dielectric Fresnel,
reflected or refracted with probability F and 1 - F; height-correlated Smith
``G2``, Heitz, JCGT 3(2), 2014), crosses the layer with ``exp(-thickness/|cos|)``,
and bounces on a Lambertian base of reflectance R, up to N times; after each bounce
it goes on along a cosine-distributed direction, reflected back down by the
interface (Fresnel with total internal reflection) or lost through it. Its mean is
``sum_k W_k``, the flux reaching the base at bounce k times R. Whatever came before,
the base sends its flux out with the same radiance per unit flux towards ``wo``,
``C(wo) = integral (u_z/pi) exp(-thickness/u_z) f_t(-u -> wo) du`` with Walter's
BTDF (eq. 21, the ``eta^2`` of radiance included), estimated separately with cosine
directions and refractions of ``wo`` (one-sample balance heuristic). The diffuse
term is ``C(wo) sum_k W_k``, the product of two independent unbiased estimates; the
interface's own reflection is added from the same formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from brdffit.data.geometry import Geometry, directions_from_angles
from brdffit.export.pbrt_layer import coated_brdf

SIGMAS = 4.0  # agreement asked for, in standard errors of the walk
N_PATHS = 200_000


def fresnel(c, eta):
    """Unpolarised dielectric Fresnel at ``cos = c`` from the side of index 1 into
    ``eta`` (``eta < 1``: leaving the denser side; 1 past the critical angle)."""
    s2 = (1 - c * c) / (eta * eta)
    ct = np.sqrt(np.maximum(1 - s2, 0.0))
    rs = (c - eta * ct) / (c + eta * ct)
    rp = (eta * c - ct) / (eta * c + ct)
    return np.where(s2 >= 1, 1.0, 0.5 * (rs * rs + rp * rp))


def lam(z, a):
    z2 = z * z
    return 0.5 * (np.sqrt(1 + a * a * (1 - z2) / z2) - 1)


def ggx(mz, a):
    c2 = mz * mz
    return 1 / (math.pi * a * a * c2 * c2 * (1 + (1 - c2) / (c2 * a * a)) ** 2)


def dot(u, v):
    return np.sum(u * v, axis=-1)


def sample_normals(rng, n, a):
    """GGX normals with density ``D(m) cos(theta_m)`` (Walter et al. 2007)."""
    x1, x2 = rng.random(n), rng.random(n)
    t2 = a * a * x1 / (1 - x1)
    cz = 1 / np.sqrt(1 + t2)
    sz = np.sqrt(1 - cz * cz)
    phi = 2 * math.pi * x2
    return np.stack([sz * np.cos(phi), sz * np.sin(phi), cz], axis=-1)


def cosine_directions(rng, n):
    r, phi = np.sqrt(rng.random(n)), 2 * math.pi * rng.random(n)
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - r * r)], axis=-1)


def interface(rng, v, a, eta):
    """Light from direction ``v`` (z > 0, pointing away from the interface) meets it
    from a medium of index 1 into ``eta``: (weight, transmitted?, new direction)."""
    m = sample_normals(rng, len(v), a)
    c = dot(v, m)
    ok = c > 0
    c = np.where(ok, c, 1.0)
    f = fresnel(c, eta)
    transmit = rng.random(len(v)) >= f
    ct = np.sqrt(np.maximum(1 - (1 - c * c) / (eta * eta), 0.0))
    out = np.where(
        transmit[:, None],
        (c / eta - ct)[:, None] * m - v / eta,  # refracted, z < 0 if valid
        2 * c[:, None] * m - v,  # reflected, z > 0 if valid
    )
    ok &= np.where(transmit, out[:, 2] < 0, out[:, 2] > 0)
    oz = np.where(ok, np.abs(out[:, 2]), 1.0)
    g2 = 1 / (1 + lam(v[:, 2], a) + lam(oz, a))
    weight = np.where(ok, c * g2 / (v[:, 2] * m[:, 2]), 0.0)
    return weight, transmit, out


def btdf_out(u_in, wo, a, eta):
    """Walter's BTDF (eq. 21) for light from inside (travelling along ``u_in``, z > 0)
    leaving towards ``wo`` (z > 0), indices eta -> 1."""
    i = -u_in  # pointing away from the interface, into the layer
    h = -(eta * i + wo)
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    h = np.where(h[:, 2:] < 0, -h, h)
    ih, oh = dot(i, h), dot(wo, h)
    ok = (ih * i[:, 2] > 0) & (oh * wo[:, 2] > 0)
    f = fresnel(np.abs(ih), 1 / eta)
    g2 = 1 / (1 + lam(np.abs(i[:, 2]), a) + lam(wo[:, 2], a))
    value = np.abs(ih * oh) / np.abs(i[:, 2] * wo[:, 2]) * (1 - f) * g2 * ggx(h[:, 2], a)
    value /= (eta * ih + oh) ** 2
    return np.where(ok, value, 0.0)


def refracted_density(u, wo, a, eta):
    """Density of ``u = -t``, ``t`` the refraction of ``wo`` into the layer through a
    normal drawn from ``D(m) cos(theta_m)`` (Walter et al. 2007, eqs. 13 and 17)."""
    t = -u
    h = -(wo + eta * t)
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    h = np.where(h[:, 2:] < 0, -h, h)
    ih, th = dot(wo, h), dot(t, h)
    ok = (ih > 0) & (th < 0)
    jacobian = eta * eta * np.abs(th) / (ih + eta * th) ** 2
    return np.where(ok, ggx(h[:, 2], a) * h[:, 2] * jacobian, 0.0)


def exit_integral(wo, a, eta, thickness, n, rng):
    """``C(wo) = integral (u_z / pi) exp(-thickness / u_z) f_t(-u -> wo) du``: the
    radiance towards ``wo`` per unit flux leaving the base (Lambertian). One-sample
    balance-heuristic mixture of cosine directions and refractions of ``wo``."""
    wos = np.tile(wo, (n, 1))
    _, transmit, t = interface(rng, wos, a, eta)
    by_refraction = rng.random(n) < 0.5
    u = np.where((by_refraction & transmit)[:, None], -t, cosine_directions(rng, n))
    u[:, 2] = np.where(by_refraction & ~transmit, -1.0, u[:, 2])  # no refraction: no sample
    up = u[:, 2] > 0
    uz = np.where(up, u[:, 2], 1.0)
    u = np.where(up[:, None], u, np.array([0.0, 0.0, 1.0]))
    g = uz / math.pi * np.exp(-thickness / uz) * btdf_out(u, wos, a, eta)
    f_t = fresnel(np.maximum(dot(wos, refract_normal(u, wo, eta)), 1e-12), eta)
    density = 0.5 * uz / math.pi + 0.5 * (1 - f_t) * refracted_density(u, wos, a, eta)
    value = np.where(up, g / np.maximum(density, 1e-300), 0.0)
    return value.mean(), value.std() / math.sqrt(n)


def refract_normal(u, wo, eta):
    """The microfacet normal that refracts ``wo`` into ``-u``."""
    h = eta * u - wo
    h = h / np.linalg.norm(h, axis=-1, keepdims=True)
    return np.where(h[:, 2:] < 0, -h, h)


def walk(wi, a, eta, thickness, reflectance, bounces, n, seed):
    """Mean and standard error of the flux reaching the base from ``wi``, each bounce
    weighted by R: ``sum_k W_k`` (the diffuse term is ``C(wo) sum_k W_k``)."""
    rng = np.random.default_rng(seed)
    weight, transmit, d = interface(rng, np.tile(wi, (n, 1)), a, eta)
    weight = np.where(transmit, weight, 0.0)  # reflected light is the interface's term
    total = np.zeros(n)
    for _ in range(bounces):
        weight = weight * np.exp(-thickness / np.abs(d[:, 2])) * reflectance
        total += weight
        u = cosine_directions(rng, n)
        # Back down: the interface seen from inside, mirrored (index 1/eta).
        v = u * np.array([-1.0, -1.0, 1.0])
        w2, transmit, r = interface(rng, v, a, 1 / eta)
        weight = np.where(transmit, 0.0, weight * np.exp(-thickness / u[:, 2]) * w2)
        d = -r  # travelling down again
    return total.mean(), total.std() / math.sqrt(n)


def top_reflection(wi, wo, a, eta):
    h = (wi + wo) / np.linalg.norm(wi + wo)
    g2 = 1 / (1 + lam(wi[2], a) + lam(wo[2], a))
    return ggx(h[2], a) * g2 * fresnel(float(wi @ h), eta) / (4 * wi[2] * wo[2])


CASES = [  # alpha, eta, thickness, R, maxdepth
    (0.3, 1.5, 0.01, 0.8, 10),
    (0.15, 1.3, 0.1, 0.5, 10),
    (0.5, 2.0, 0.01, 0.9, 4),
]


@pytest.mark.parametrize("case", CASES)
def test_closed_form_is_the_walk_expectation(case):
    a, eta, thickness, big_r, maxdepth = case
    q = {"form": "coateddiffuse", "reflectance": [big_r, 0.0, 1.0], "uroughness": a,
         "vroughness": a, "eta": eta, "thickness": thickness, "maxdepth": maxdepth}  # fmt: skip
    bounces = (maxdepth + 1) // 2  # pbrt's walk: a crossing per depth, the base at even ones
    wos = directions_from_angles([10.0, 45.0, 70.0], [0.0, 120.0, 200.0])
    rng = np.random.default_rng(7)
    exits = np.array([exit_integral(wo, a, eta, thickness, N_PATHS, rng) for wo in wos])
    for theta_i in (0.0, 40.0, 65.0):
        wi = directions_from_angles([theta_i], [30.0])[0]
        flux, flux_se = walk(wi, a, eta, thickness, big_r, bounces, N_PATHS, int(theta_i))
        mean = exits[:, 0] * flux
        se = mean * np.hypot(exits[:, 1] / exits[:, 0], flux_se / flux)
        got = coated_brdf(Geometry(np.tile(wi, (3, 1)), wos), q, mis=False)
        top = np.array([top_reflection(wi, wo, a, eta) for wo in wos])
        np.testing.assert_allclose(got[:, 1], top, rtol=1e-9)  # reflectance 0: the coat only
        diffuse = got[:, 0] - top
        assert np.all(se < 0.005 * diffuse), (se, diffuse)  # the walk resolves 0.5 %
        assert np.all(np.abs(diffuse - mean) < SIGMAS * se), (theta_i, diffuse, mean, se)
