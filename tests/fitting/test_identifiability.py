"""Parameters the data cannot identify are named in the result, and compare does not
crown a model for them (issue 17).

Both failed before: a fit said nothing of parameters its data could not decide
(``FitResult.unidentified`` did not exist), and compare ranked
``ashikhmin_shirley`` first on the car paint, measured at phi_i = 0 only.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import shared_file

import brdffit

TRUTH = {"alpha_u": 0.1, "alpha_v": 0.3, "kd": 0.3, "ks": 0.8}


def in_plane(azimuths=(0.0,)) -> tuple:
    """Angles of a goniometer that keeps wo in the plane of incidence, at the given
    incidence azimuths."""
    theta_i = np.repeat([10.0, 20.0, 30.0, 40.0, 50.0, 60.0], 60)
    theta_o = np.tile(np.linspace(0.0, 85.0, 30).repeat(2), 6)
    out = []
    for phi in azimuths:
        phi_i = np.full(theta_i.size, phi)
        phi_o = phi_i + np.tile([0.0, 180.0], theta_i.size // 2)
        out.append((theta_i, phi_i, theta_o, phi_o))
    return tuple(np.concatenate(a) for a in zip(*out))


@pytest.fixture(scope="module")
def car_paint():
    """20,000 samples of the NVIDIA car paint (every one at phi_i = 0)."""
    data = brdffit.read(shared_file("nvidia", "carpaint_red.mbsdf"))
    index = np.sort(np.random.default_rng(0).choice(data.n, 20_000, replace=False))
    return data.subset(index)


def test_in_plane_data_do_not_identify_the_anisotropy():
    data = brdffit.synthesize("ggx_anisotropic", TRUTH, geometry=in_plane(), noise=0.01)
    result = brdffit.fit(data, "ggx_anisotropic")
    assert set(result.unidentified) >= {"alpha_u", "alpha_v"}
    assert "incidence azimuth" in result.unidentified["alpha_u"]
    # In the plane of incidence alpha_v only scales the lobe, as ks does: the
    # Fisher information is singular along their combination.
    assert "singular" in result.unidentified["alpha_v"]
    assert "alpha_v" in result.unidentified["ks"]
    assert "not identified by the data: alpha_u, alpha_v" in result.message
    assert result.to_dict()["unidentified"] == dict(result.unidentified)


def test_the_isotropic_model_on_the_same_data_is_identified():
    data = brdffit.synthesize("ggx_anisotropic", TRUTH, geometry=in_plane(), noise=0.01)
    result = brdffit.fit(data, "ggx")
    assert dict(result.unidentified) == {}
    assert "not identified" not in result.message


def test_two_incidence_azimuths_identify_the_anisotropy():
    data = brdffit.synthesize("ggx_anisotropic", TRUTH, geometry=in_plane((0.0, 90.0)), noise=0.01)
    result = brdffit.fit(data, "ggx_anisotropic")
    assert dict(result.unidentified) == {}
    assert result.params["alpha_u"] == pytest.approx(0.1, rel=0.05)
    assert result.params["alpha_v"] == pytest.approx(0.3, rel=0.05)


def test_an_unseen_lobe_has_an_unidentified_shape():
    """With ks = 0 (or 1e-15) in every channel the data cannot see the lobe's shape."""
    data = brdffit.synthesize("lambert", {"kd": [0.6, 0.35, 0.2]})
    result = brdffit.fit(data, "blinn", loss="l2")
    assert np.all(np.asarray(result.params["ks"]) < 1e-9)
    assert "n" in result.unidentified, result.message


def test_the_car_paint_anisotropy_is_flagged(car_paint):
    result = brdffit.fit(car_paint, "ggx_anisotropic", loss="l2")
    assert set(result.unidentified) == {"alpha_u", "alpha_v"}
    assert "phi_i = 0 deg" in result.unidentified["alpha_u"]
    assert dict(brdffit.fit(car_paint, "ggx", loss="l2").unidentified) == {}


def test_compare_does_not_crown_an_unidentified_anisotropy(car_paint):
    comparison = brdffit.compare(car_paint, ["ashikhmin_shirley", "ggx_anisotropic", "ggx"],
                                 loss="l2")  # fmt: skip
    by_name = {e.model: e for e in comparison.entries}
    # Without the rule the anisotropic fits have the lower BIC (more freedom).
    assert by_name["ashikhmin_shirley"].bic < by_name["ggx"].bic
    assert comparison.best_by_bic == "ggx"
    assert comparison.best_by_heldout == "ggx"
    assert by_name["ggx"].rank_bic == 1 and by_name["ggx"].rank_heldout == 1
    text = str(comparison)
    assert "ashikhmin_shirley *" in text and "do not identify" in text


def test_the_command_line_says_it_in_one_line(tmp_path, capsys):
    from brdffit.cli.main import main

    path = tmp_path / "in_plane.csv"
    brdffit.write(path, brdffit.synthesize("ggx_anisotropic", TRUTH, geometry=in_plane(),
                                           noise=0.01))  # fmt: skip
    assert main(["fit", str(path), "--model", "ggx_anisotropic"]) == 0
    lines = [x for x in capsys.readouterr().out.splitlines() if x.startswith("NOT IDENTIFIED")]
    assert len(lines) == 1
    assert "alpha_u, alpha_v: every sample has the incidence azimuth phi_i = 0" in lines[0]


def test_a_linear_parameter_at_zero_is_reported_with_its_sd_not_a_relative_width():
    """At f0 = 0 the relative width sd / |f0| is infinite: it was printed as 2.44e+297
    (ggx on a whole MERL file of cook_torrance data). The message gives value +- sd."""
    from brdffit.fitting.identifiability import _judge

    info = np.array([[4.0, 0.0], [0.0, 1e4]])  # sd 0.5 for f0, 0.01 for alpha
    out = _judge(["f0", "alpha"], ["linear", "log"], info, {"f0": 0.0, "alpha": 0.2})
    assert set(out) == {"f0"}
    assert "0 +- 0.5" in out["f0"] and "e+" not in out["f0"], out
    out = _judge(["f0"], ["linear"], info[:1, :1], {"f0": 0.05})  # sd 10 times |f0|
    assert "0.05 +- 0.5" in out["f0"], out
    assert _judge(["f0"], ["linear"], info[:1, :1], {"f0": 0.6}) == {}  # width 0.83


@pytest.mark.parametrize("channels", [(0, 0, 1, 2, 2), (0, 1, 2, 0, 1, 2), (1, 2)])
@pytest.mark.parametrize("n_dense", [0, 2])
def test_the_information_is_j_transpose_w_j(channels, n_dense):
    """The information from its compact sources equals J^T W J of the explicit
    Jacobian: a shape column (M, C) fills every channel's residuals, a coefficient of
    channel c only channel c's (its columns vectorised over channels since issue 13)."""
    from brdffit.fitting.information import channel_information

    rng = np.random.default_rng(5)
    m, c = 40, 3
    sqrt_w = rng.uniform(0.5, 2.0, (m, c))
    dense = [rng.standard_normal((m, c)) for _ in range(n_dense)]
    pairs = [(ch, rng.standard_normal(m)) for ch in channels]
    jacobian = np.zeros((m * c, len(dense) + len(pairs)))  # rows: sample-major, channel
    for j, col in enumerate(dense):
        jacobian[:, j] = (col * sqrt_w).ravel()
    for j, (ch, v) in enumerate(pairs, len(dense)):
        column = np.zeros((m, c))
        column[:, ch] = v * sqrt_w[:, ch]
        jacobian[:, j] = column.ravel()
    # each coefficient its own source, zero outside its channel
    sources = dense + [np.zeros((m, c)) for _ in pairs]
    for k, (ch, v) in enumerate(pairs, len(dense)):
        sources[k][:, ch] = v
    layout = [(k, -1) for k in range(len(dense))]
    layout += [(k, ch) for k, (ch, _) in enumerate(pairs, len(dense))]
    np.testing.assert_allclose(
        channel_information(sources, layout, sqrt_w), jacobian.T @ jacobian,
        rtol=1e-12, atol=1e-12,
    )  # fmt: skip
