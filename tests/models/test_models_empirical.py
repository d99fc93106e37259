"""The isotropic empirical models of brdffit/models/empirical.py.

Reference values come from scalar code written here with the math module from
MODELS.md (and, for Oren-Nayar, from the angle form of the 1994 paper), never
from the vectorised code. The paper's claims on Schlick, Romanyuk and Blake are
measured on the registered models.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from helpers import hemisphere_pairs

from brdffit import get_model

MINE = (
    "lambert",
    "phong",
    "phong_normalized",
    "blinn",
    "blinn_normalized",
    "schlick",
    "romanyuk",
    "gaussian",
    "blake",
    "lafortune",
    "oren_nayar",
)

# (theta_i, phi_i, theta_o, phi_o) in degrees.
PAIRS = (
    (30.0, 0.0, 30.0, 180.0),  # mirror pair: H = N
    (0.0, 0.0, 0.0, 0.0),  # L = V = N
    (89.9, 10.0, 89.5, 190.0),  # both grazing, near the mirror direction
    (89.99, 0.0, 40.0, 90.0),  # grazing light
    (45.0, 10.0, 20.0, 100.0),
    (60.0, 30.0, 60.0, 30.0),  # L = V away from the normal (retro-reflection)
    (70.0, 200.0, 15.0, 340.0),
    (20.0, 0.0, 25.0, 175.0),  # near the mirror direction
)

# Every test here runs on the compiled kernels and on the numpy formulas.
pytestmark = pytest.mark.usefixtures("evaluation_path")


def unit(theta_deg: float, phi_deg: float) -> tuple:
    t, p = math.radians(theta_deg), math.radians(phi_deg)
    return (math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t))


def dot(a, b) -> float:
    return sum(x * y for x, y in zip(a, b))


# ------------------------------------------------------- scalar references
def cos_n(c: float, n: float) -> float:
    return c**n


def blake_scalar(g: float, n: float) -> float:
    a = (n + 5.6) / (n * (0.09 * n + 5.2))
    b = (n + 65) / (5 * n + 31.7)
    if g <= a:
        return 1 - g * g / (a * b)
    if g <= b:
        return (g - b) ** 2 / (b * (b - a))
    return 0.0


def lobe_scalar(name: str, p: dict, L, V) -> float:
    """The lobe (or, for Oren-Nayar, the whole BRDF over kd) of MODELS.md."""
    s = [x + y for x, y in zip(L, V)]
    h = [x / math.sqrt(dot(s, s)) for x in s]
    c = h[2]
    theta_h = math.acos(min(c, 1.0))
    r_dot_v = dot((-L[0], -L[1], L[2]), V)
    n = p.get("n")
    if name in ("phong", "phong_normalized"):
        lobe = max(0.0, r_dot_v) ** n
        return lobe * (n + 2) / (2 * math.pi) if name == "phong_normalized" else lobe
    if name in ("blinn", "blinn_normalized"):
        return c**n * ((n + 8) / (8 * math.pi) if name == "blinn_normalized" else 1.0)
    if name == "schlick":
        return c / (n - n * c + c)
    if name == "romanyuk":
        return max(0.0, 1 + 7 * n / 16 * (c - 1)) ** 2
    if name == "gaussian":
        return math.exp(-n * theta_h**2 / 2)
    if name == "blake":
        return blake_scalar(theta_h, n)
    if name == "lafortune":
        base = p["cxy"] * (L[0] * V[0] + L[1] * V[1]) + L[2] * V[2]
        return max(0.0, base) ** n
    raise KeyError(name)


def oren_nayar_scalar(sigma: float, L, V) -> float:
    """``(A + B max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta)) / pi`` in angles."""
    theta_i, theta_o = math.acos(L[2]), math.acos(V[2])
    phi_i, phi_o = math.atan2(L[1], L[0]), math.atan2(V[1], V[0])
    alpha, beta = max(theta_i, theta_o), min(theta_i, theta_o)
    s2 = sigma * sigma
    a = 1 - 0.5 * s2 / (s2 + 0.33)
    b = 0.45 * s2 / (s2 + 0.09)
    return (a + b * max(0.0, math.cos(phi_i - phi_o)) * math.sin(alpha) * math.tan(beta)) / math.pi


def brdf_scalar(name: str, p: dict, L, V) -> float:
    if name == "lambert":
        return p["kd"] / math.pi
    if name == "oren_nayar":
        return p["kd"] * oren_nayar_scalar(p["sigma"], L, V)
    return p["kd"] / math.pi + p["ks"] * lobe_scalar(name, p, L, V)


def param_sets(name: str):
    if name == "lambert":
        return [{"kd": 0.7}]
    if name == "oren_nayar":
        return [{"kd": 0.8, "sigma": s} for s in (0.0, 0.35, 1.2, math.pi / 2)]
    exponents = (1.0, 7.5, 300.0) if name != "blake" else (1.0, 7.5, 1000.0)
    sets = []
    for n in exponents:
        for kd, ks in ((0.0, 1.0), (0.3, 2.5)):
            p = {"kd": kd, "ks": ks, "n": n}
            if name == "lafortune":
                sets += [dict(p, cxy=cxy) for cxy in (-1.0, -0.3, 0.6)]
            else:
                sets.append(p)
    return sets


@pytest.mark.parametrize("name", MINE)
def test_matches_an_independent_scalar_implementation(name):
    model = get_model(name)
    dirs = [(unit(ti, pi_), unit(to, po)) for ti, pi_, to, po in PAIRS]
    wi = np.array([d[0] for d in dirs])
    wo = np.array([d[1] for d in dirs])
    for p in param_sets(name):
        got = model.evaluate(wi, wo, p)
        want = np.array([brdf_scalar(name, p, L, V) for L, V in dirs])
        # exp(n ln c) amplifies the rounding of ln c by n |ln c| (< 750 before
        # underflow): relative errors stay far below 1e-10.
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-300, err_msg=str(p))


# ------------------------------------------------------ the paper's claims
def lobe_along_theta_h(name: str, n: float, g: np.ndarray) -> np.ndarray:
    """The registered lobe (kd = 0, ks = 1) at theta_h = g: L = V at polar angle g."""
    w = np.stack([np.sin(g), np.zeros_like(g), np.cos(g)], axis=-1)
    return get_model(name).evaluate(w, w, {"kd": 0.0, "ks": 1.0, "n": n})


def errors_up_to_inflection(n: float):
    """Schlick's relative and absolute, and Romanyuk's absolute, error against cos^n
    on [0, g*], tan^2 g* = 1/(n - 1)."""
    g = np.linspace(0.0, math.atan(1.0 / math.sqrt(n - 1.0)), 4001)
    ref = np.array([cos_n(math.cos(x), n) for x in g])
    schlick = lobe_along_theta_h("schlick", n, g)
    romanyuk = lobe_along_theta_h("romanyuk", n, g)
    return (
        float(np.max(np.abs(schlick / ref - 1.0))),
        float(np.max(np.abs(schlick - ref))),
        float(np.max(np.abs(romanyuk - ref))),
    )


EXPONENTS = (5.0, 6.0, 8.0, 10.0, 15.0, 30.0, 100.0, 1000.0, 1e4)


def test_schlick_within_ten_percent_of_cos_n_up_to_the_inflection_point():
    for n in (2.0, 3.0, *EXPONENTS):
        rel, _, _ = errors_up_to_inflection(n)
        assert rel <= 0.10, f"n={n}: Schlick's relative error {rel:.4f} exceeds 10 %"


def limit_ratio() -> float:
    """Schlick's over Romanyuk's max error as n -> inf: with u = n (1 - c) in [0, 1/2]
    (the inflection is at 1 - c ~ 1/(2n)), cos^n -> exp(-u), Schlick -> 1/(1 + u),
    Romanyuk -> (1 - 7u/16)^2."""
    u = [0.5 * k / 20000 for k in range(20001)]
    schlick = max(abs(1 / (1 + x) - math.exp(-x)) for x in u)
    romanyuk = max(abs((1 - 7 * x / 16) ** 2 - math.exp(-x)) for x in u)
    return schlick / romanyuk


def test_romanyuk_beats_schlick_up_to_the_inflection_point():
    """At least 2.5x smaller max error for n >= 5; for n >= 10 at least 3x, growing
    with n towards the n -> inf ratio (about 4.2), never above it."""
    ceiling = limit_ratio()
    ratios = []
    for n in EXPONENTS:
        _, schlick, romanyuk = errors_up_to_inflection(n)
        ratios.append(schlick / romanyuk)
        assert ratios[-1] >= 2.5, f"n={n}: ratio {ratios[-1]:.2f}"
        if n >= 10:
            assert 3.0 <= ratios[-1] <= ceiling + 1e-3, f"n={n}: ratio {ratios[-1]:.2f}"
    assert all(b >= a - 1e-9 for a, b in itertools.pairwise(ratios)), ratios
    assert ratios[-1] == pytest.approx(ceiling, rel=1e-2)


@pytest.mark.parametrize("n", (3.0, 10.0, 100.0, 1e4))
def test_romanyuk_is_exactly_zero_past_its_cutoff(n):
    cutoff = math.acos(1.0 - 16.0 / (7.0 * n))
    inside = lobe_along_theta_h("romanyuk", n, np.linspace(0.0, cutoff * (1 - 1e-6), 500))
    outside = lobe_along_theta_h("romanyuk", n, np.linspace(cutoff * (1 + 1e-6), 1.57, 500))
    assert (inside > 0).all()
    assert (np.diff(inside) <= 0).all(), "the lobe must fall monotonically to the cut-off"
    assert (outside == 0.0).all(), f"rises again to {outside.max():g} past the cut-off"


@pytest.mark.parametrize("n", (1.0, 10.0, 100.0, 1000.0))
def test_blake_is_c1_at_both_breakpoints(n):
    a = (n + 5.6) / (n * (0.09 * n + 5.2))
    b = (n + 65) / (5 * n + 31.7)
    curvature = {a: 2 / (a * b) + 2 / (b * (b - a)), b: 2 / (b * (b - a))}
    slope = {a: -2 / b, b: 0.0}
    for g in (a, b):
        if g > math.pi / 2 - 1e-3:
            continue  # b = 1.8 rad at n = 1: beyond the reachable theta_h <= pi/2
        h = 1e-6 * g
        left, mid, right = lobe_along_theta_h("blake", n, np.array([g - h, g, g + h]))
        d_left, d_right = (mid - left) / h, (right - mid) / h
        # Each one-sided difference is within h |f''| / 2 of its one-sided derivative;
        # the rounding of values near 1 adds a few 1e-16 / h. A kink would show as a
        # jump of order 1 (the slope is -2/b at a).
        tolerance = h * curvature[g] + 4e-15 / h
        assert abs(d_left - d_right) <= tolerance, (g, d_left, d_right)
        assert d_left == pytest.approx(slope[g], abs=tolerance)
        assert abs(right - left) <= 2 * h * abs(slope[g]) + h * h * curvature[g] + 1e-14


# ----------------------------------------------------- normalised variants
def normal_incidence_albedo(name: str, n: float) -> float:
    """integral f cos(theta_o) dw_o at wi = N, with f the lobe (kd = 0, ks = 1).

    Composite 24-point Gauss-Legendre in u = cos(theta_o) on panels that halve
    towards u = 1 (where the lobe lives), trapezoid in phi (exact for a periodic,
    here constant, integrand). The quadrature error is below 1e-12 for these n.
    """
    edges = np.concatenate([1.0 - 0.5 ** np.arange(0, 45), [1.0]])
    x, w = np.polynomial.legendre.leggauss(24)
    lo, hi = edges[:-1, None], edges[1:, None]
    u = (0.5 * (hi - lo) * x + 0.5 * (hi + lo)).ravel()
    wu = (0.5 * (hi - lo) * w).ravel()
    phi = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    s = np.sqrt(1.0 - u * u)
    wo = np.stack(
        [
            np.multiply.outer(np.cos(phi), s),
            np.multiply.outer(np.sin(phi), s),
            np.broadcast_to(u, (phi.size, u.size)),
        ],
        axis=-1,
    ).reshape(-1, 3)
    wi = np.broadcast_to([0.0, 0.0, 1.0], wo.shape)
    f = get_model(name).evaluate(wi, wo, {"kd": 0.0, "ks": 1.0, "n": n})
    f = f.reshape(phi.size, u.size)
    return float((2 * np.pi / phi.size) * np.sum(f * u * wu))


@pytest.mark.parametrize("n", (1.0, 10.0, 100.0, 1000.0, 1e4))
def test_normalised_phong_has_unit_albedo_at_normal_incidence(n):
    """There R.V = cos(theta_o) and (n+2)/(2 pi) int cos^(n+1) dw = 1 for every n."""
    assert normal_incidence_albedo("phong_normalized", n) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("n", (1.0, 10.0, 100.0, 1000.0, 1e4))
def test_normalised_blinn_albedo_at_normal_incidence(n):
    """theta_h = theta_o / 2; with s = (1 + u)/2 the integral is
    (n+8)/(8 pi) 2 pi [4 (1 - 2^-(n/2+2))/(n/2+2) - 2 (1 - 2^-(n/2+1))/(n/2+1)],
    about 1 + 2/n: close to 1 for large n."""
    m = n / 2
    exact = (n + 8) / 4 * (4 * (1 - 2 ** -(m + 2)) / (m + 2) - 2 * (1 - 2 ** -(m + 1)) / (m + 1))
    albedo = normal_incidence_albedo("blinn_normalized", n)
    assert albedo == pytest.approx(exact, rel=1e-9)
    if n >= 10:
        assert abs(albedo - 1.0) < 2.0 / n


# ------------------------------------------------------ special cases
def test_lafortune_with_cxy_minus_one_is_phong():
    wi, wo = hemisphere_pairs(2000, seed=11)
    for n in (1.0, 20.0, 1000.0):
        p = {"kd": 0.2, "ks": 1.5, "n": n}
        phong = get_model("phong").evaluate(wi, wo, p)
        lafortune = get_model("lafortune").evaluate(wi, wo, dict(p, cxy=-1.0))
        # The two compute R.V with different roundings (~1e-16 absolute).
        np.testing.assert_allclose(lafortune, phong, rtol=1e-9, atol=1e-13)


def test_oren_nayar_with_zero_roughness_is_lambert():
    wi, wo = hemisphere_pairs(2000, seed=12)
    lambert = get_model("lambert").evaluate(wi, wo, {"kd": 0.6})
    oren_nayar = get_model("oren_nayar").evaluate(wi, wo, {"kd": 0.6, "sigma": 0.0})
    np.testing.assert_allclose(oren_nayar, lambert, rtol=1e-15, atol=0)
    rough = get_model("oren_nayar").evaluate(wi, wo, {"kd": 0.6, "sigma": 0.5})
    assert np.abs(rough - lambert).max() > 0.01, "roughness must change the values"


def test_classification():
    for name in MINE:
        cls = get_model(name).classification
        assert cls.symmetry == "isotropic" and cls.highlight == "light" and not cls.wave_optics
        assert cls.operand == ("angle" if name in ("gaussian", "blake") else "cosine"), name
        assert cls.origin == ("physical" if name == "oren_nayar" else "empirical"), name
