"""The binary measured formats: MERL (.binary) and NVIDIA MBSDF (.mbsdf).

Reference values come from code written here from the primary sources: a
scalar port of MERL's BRDFRead.cpp lookup (math module, acos as in the
original) and byte layouts packed with struct, never from the module's own
vectorised functions.
"""

from __future__ import annotations

import math
import struct
import tracemalloc

import numpy as np
import pytest
from helpers import hemisphere_pairs, shared_file
from io_helpers import MAGIC, REFLECTION, TRANSMISSION, pack_block

from brdffit import DataError, FormatError, get_model
from brdffit.data.measurements import Measurements
from brdffit.io import merl
from brdffit.io.mbsdf import read_mbsdf, read_mbsdf_arrays

# --------------------------------------------------------------------------- MERL
# Constants of BRDFRead.cpp.
RES_TH, RES_TD, RES_PD = 90, 90, 180
N_CELLS = RES_TH * RES_TD * RES_PD
REF_SCALE = (1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0)
HEADER = 12  # three int32
FILE_SIZE = HEADER + 3 * N_CELLS * 8


def _rotate(v, axis, angle):
    """BRDFRead.cpp's rotate_vector (Rodrigues), scalar."""
    c, s = math.cos(angle), math.sin(angle)
    dot = sum(a * b for a, b in zip(axis, v))
    cross = (
        axis[1] * v[2] - axis[2] * v[1],
        axis[2] * v[0] - axis[0] * v[2],
        axis[0] * v[1] - axis[1] * v[0],
    )
    return tuple(v[m] * c + axis[m] * dot * (1 - c) + cross[m] * s for m in range(3))


def reference_cell(wi, wo):
    """Port of std_coords_to_half_diff_coords and the three index functions."""
    h = [a + b for a, b in zip(wi, wo)]
    norm = math.sqrt(sum(x * x for x in h))
    h = [x / norm for x in h]
    theta_h = math.acos(max(-1.0, min(1.0, h[2])))
    phi_h = math.atan2(h[1], h[0])
    temp = _rotate(wi, (0.0, 0.0, 1.0), -phi_h)
    diff = _rotate(temp, (0.0, 1.0, 0.0), -theta_h)
    theta_d = math.acos(max(-1.0, min(1.0, diff[2])))
    phi_d = math.atan2(diff[1], diff[0])
    if theta_h <= 0:
        i = 0
    else:
        i = min(max(int(math.sqrt(theta_h / (math.pi / 2) * RES_TH * RES_TH)), 0), RES_TH - 1)
    j = min(max(int(theta_d / (math.pi * 0.5) * RES_TD), 0), RES_TD - 1)
    if phi_d < 0:
        phi_d += math.pi
    k = min(max(int(phi_d / math.pi * RES_PD), 0), RES_PD - 1)
    return i, j, k


def reference_centre(i, j, k):
    """Centre angles of a cell (module docstring) turned into (wi, wo) by rotating the
    difference vector back with the reference's rotate_vector."""
    theta_h = ((i + 0.5) / RES_TH) ** 2 * math.pi / 2
    theta_d = (j + 0.5) / RES_TD * math.pi / 2
    phi_d = (k + 0.5) / RES_PD * math.pi
    d = (
        math.sin(theta_d) * math.cos(phi_d),
        math.sin(theta_d) * math.sin(phi_d),
        math.cos(theta_d),
    )
    wi = _rotate(d, (0.0, 1.0, 0.0), theta_h)
    h = _rotate((0.0, 0.0, 1.0), (0.0, 1.0, 0.0), theta_h)
    dot = sum(a * b for a, b in zip(wi, h))
    wo = tuple(2 * dot * h[m] - wi[m] for m in range(3))
    return wi, wo


def code_table():
    """Stored values that name their own cell: code = flat index + 1, or -1 (invalid)."""
    c, i, j, k = np.indices((3, RES_TH, RES_TD, RES_PD))
    table = (((c * RES_TH + i) * RES_TD + j) * RES_PD + k + 1).astype(float)
    invalid = (i + 2 * j + 3 * k) % 7 == 0  # same cells in every channel
    table[invalid] = -1.0
    return table


def decode(stored_red):
    flat = np.rint(stored_red).astype(np.int64) - 1
    return np.unravel_index(flat, (RES_TH, RES_TD, RES_PD))


def pack_merl(path, table, dims=(90, 90, 180)):
    with open(path, "wb") as f:
        f.write(struct.pack("<3i", *dims))
        f.write(np.ascontiguousarray(table, dtype="<f8").tobytes())


@pytest.fixture(scope="module")
def ones_file(tmp_path_factory):
    """A full file with stored value 1500 in every cell: BRDF (1, 1.15, 1.66)."""
    path = tmp_path_factory.mktemp("merl") / "ones.binary"
    pack_merl(path, np.full((3, RES_TH, RES_TD, RES_PD), 1500.0))
    return path


@pytest.fixture(scope="module")
def code_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("merl") / "codes.binary"
    pack_merl(path, code_table())
    return path


@pytest.fixture(scope="module")
def code_samples(code_file):
    return merl.read_merl_arrays(code_file)


def test_merl_reads_the_reference_layout_scales_and_directions(code_samples):
    s = code_samples
    i, j, k = decode(s.values[:, 0] / REF_SCALE[0])
    for c in range(3):  # channel-major, each with its own scale
        expected = ((c * RES_TH + i) * RES_TD + j) * RES_PD + k + 1
        np.testing.assert_allclose(s.values[:, c], expected * REF_SCALE[c], rtol=1e-15)
    assert ((i + 2 * j + 3 * k) % 7 != 0).all()  # no invalid cell came back
    rng = np.random.default_rng(3)
    for n in rng.choice(s.wi.shape[0], 400, replace=False):
        wi, wo = tuple(s.wi[n]), tuple(s.wo[n])
        # MERL's own lookup of the returned directions finds the cell of the value ...
        assert reference_cell(wi, wo) == (i[n], j[n], k[n])
        # ... and the directions are that cell's centre
        ref_wi, ref_wo = reference_centre(i[n], j[n], k[n])
        np.testing.assert_allclose(wi, ref_wi, atol=1e-12)
        np.testing.assert_allclose(wo, ref_wo, atol=1e-12)


def test_merl_drops_negative_cells_and_cells_below_the_horizon(code_samples):
    s = code_samples
    i, j, k = decode(s.values[:, 0] / REF_SCALE[0])
    returned = np.zeros((RES_TH, RES_TD, RES_PD), bool)
    returned[i, j, k] = True
    ii, jj, kk = np.indices(returned.shape)
    negative = (ii + 2 * jj + 3 * kk) % 7 == 0
    assert s.n_cells == N_CELLS
    assert s.n_negative == negative.sum()
    assert s.wi.shape[0] + s.n_negative + s.n_below_horizon == N_CELLS
    assert s.n_below_horizon > 0
    missing = np.argwhere(~returned & ~negative)
    assert len(missing) == s.n_below_horizon
    rng = np.random.default_rng(4)
    for cell in missing[rng.choice(len(missing), 200, replace=False)]:
        wi, wo = reference_centre(*cell)
        assert min(wi[2], wo[2]) <= 0
    assert (s.wi[:, 2] > 0).all() and (s.wo[:, 2] > 0).all()


def test_merl_subsample_keeps_every_kth_cell_per_axis(code_file, code_samples):
    full = code_samples
    sub = merl.read_merl_arrays(code_file, subsample=4)
    i, j, k = decode(sub.values[:, 0] / REF_SCALE[0])
    assert (i % 4 == 0).all() and (j % 4 == 0).all() and (k % 4 == 0).all()
    fi, fj, fk = decode(full.values[:, 0] / REF_SCALE[0])
    on_grid = (fi % 4 == 0) & (fj % 4 == 0) & (fk % 4 == 0)
    assert sub.wi.shape[0] == on_grid.sum()
    np.testing.assert_array_equal(sub.values, full.values[on_grid])
    np.testing.assert_array_equal(sub.wi, full.wi[on_grid])
    np.testing.assert_array_equal(sub.wo, full.wo[on_grid])


def test_merl_subsample_of_a_full_file_gives_the_grid_directions(ones_file):
    sub = merl.read_merl_arrays(ones_file, subsample=4)
    wi, wo = merl.grid_directions(4)
    np.testing.assert_array_equal(sub.wi, wi)
    np.testing.assert_array_equal(sub.wo, wo)
    assert sub.n_cells == len(range(0, 90, 4)) ** 2 * len(range(0, 180, 4))
    assert sub.n_negative == 0 and sub.n_below_horizon == sub.n_cells - len(wi)


@pytest.mark.parametrize("bad", [0, -2, 1.5, True, "3"])
def test_merl_subsample_must_be_a_positive_whole_number(code_file, bad):
    with pytest.raises(DataError, match="subsample"):
        merl.read_merl_arrays(code_file, subsample=bad)


def test_cell_indices_agree_with_the_reference_lookup():
    wi, wo = hemisphere_pairs(3000, seed=5)
    above = (wi[:, 2] > 0) & (wo[:, 2] > 0)
    # where wi = wo, theta_d = 0 and phi_d is undefined (rounding picks it in either code)
    defined = np.linalg.norm(wi - wo, axis=1) > 1e-9
    wi, wo = wi[above & defined], wo[above & defined]
    assert len(wi) > 1000
    i, j, k = merl.cell_indices(wi, wo)
    for n in range(len(wi)):
        assert reference_cell(tuple(wi[n]), tuple(wo[n])) == (i[n], j[n], k[n]), n


def test_grid_directions_are_the_centres_of_the_cells_above_the_horizon():
    wi, wo = merl.grid_directions(step=5)
    assert (wi[:, 2] > 0).all() and (wo[:, 2] > 0).all()
    np.testing.assert_allclose(np.linalg.norm(wi, axis=1), 1.0, atol=1e-14)
    cells = {reference_cell(tuple(a), tuple(b)) for a, b in zip(wi[::17], wo[::17])}
    assert all(i % 5 == 0 and j % 5 == 0 and k % 5 == 0 for i, j, k in cells)
    count = 0
    for i in range(0, RES_TH, 5):
        for j in range(0, RES_TD, 5):
            for k in range(0, RES_PD, 5):
                a, b = reference_centre(i, j, k)
                count += a[2] > 0 and b[2] > 0
    assert len(wi) == count


def _blinn_rgb(wi, wo):
    params = {"kd": [0.2, 0.1, 0.05], "ks": [3.0, 2.0, 1.0], "n": 40.0}
    return get_model("blinn").evaluate(wi, wo, params)


def test_merl_round_trip_of_a_model_agrees_with_the_model(tmp_path):
    wi, wo = merl.grid_directions(step=3)
    data = Measurements(wi, wo, _blinn_rgb(wi, wo), channels=("r", "g", "b"))
    path = tmp_path / "blinn.binary"
    merl.write_merl(path, data)
    assert path.stat().st_size == FILE_SIZE
    back = merl.read_merl(path)
    assert back.channels == ("r", "g", "b") and back.units == "1/sr"
    np.testing.assert_array_equal(back.wi, wi)
    np.testing.assert_array_equal(back.wo, wo)
    # stored as value / scale in doubles and read back times scale: a few ulp
    np.testing.assert_allclose(back.values, _blinn_rgb(back.wi, back.wo), rtol=1e-15, atol=0)
    stored = np.frombuffer(path.read_bytes(), dtype="<f8", offset=HEADER).reshape(3, -1)
    # cells without a sample are written as -1, in every channel
    assert (stored == -1.0).all(axis=0).sum() == N_CELLS - len(wi)


def test_write_merl_bins_samples_to_cells_and_averages_them(tmp_path):
    wi, wo = reference_centre(10, 20, 30)
    # a second direction pair inside the same cell: rotate both about the normal
    a = 0.3
    rot = np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])
    wi2, wo2 = rot @ np.array(wi), rot @ np.array(wo)
    assert reference_cell(tuple(wi2), tuple(wo2)) == (10, 20, 30)
    values = np.array([[1.0, 2.0, 3.0], [3.0, 6.0, 9.0]])
    path = tmp_path / "two.binary"
    merl.write_merl(path, Measurements([wi, wi2], [wo, wo2], values, channels=("r", "g", "b")))
    back = merl.read_merl(path)
    assert back.n == 1
    np.testing.assert_allclose(back.values[0], values.mean(axis=0), rtol=1e-15)
    np.testing.assert_allclose(back.wi[0], wi, atol=1e-12)


def test_write_merl_needs_three_channels_non_negative_values_above_the_horizon(tmp_path):
    wi, wo = merl.grid_directions(step=30)
    path = tmp_path / "x.binary"
    one = Measurements(wi, wo, np.ones(len(wi)))
    with pytest.raises(DataError, match="3") as err:
        merl.write_merl(path, one)
    assert err.value.field == "channels" and "1 channel" in str(err.value)
    values = np.ones((len(wi), 3))
    values[2, 1] = -0.5
    with pytest.warns(UserWarning):
        negative = Measurements(wi, wo, values, channels=("r", "g", "b"))
    with pytest.raises(DataError, match=r"values\[2\]"):
        merl.write_merl(path, negative)
    below = np.array(wo)
    below[0] = [0.0, 0.6, -0.8]
    with pytest.raises(DataError, match="horizon"):
        merl.write_merl(
            path, Measurements(wi, below, np.ones((len(wi), 3)), channels=("r", "g", "b"))
        )
    assert not path.exists()


@pytest.mark.parametrize(
    "make, pattern",
    [
        (lambda: b"\x5a\x00\x00\x00\x5a", r"has 5 bytes.*header.*byte 0"),
        (lambda: struct.pack("<3i", 90, 90, 360), rf"\[90, 90, 360\] at byte 0.*{90 * 90 * 360}"),
        (lambda: struct.pack("<3i", -90, -90, 180), r"\[-90, -90, 180\] at byte 0"),
        (
            lambda: struct.pack("<3i", 90, 90, 180) + bytes(800),
            rf"truncated: it ends at byte {HEADER + 800}.*end at byte {FILE_SIZE}",
        ),
    ],
)
def test_merl_header_and_size_errors_name_the_byte(tmp_path, make, pattern):
    path = tmp_path / "bad.binary"
    path.write_bytes(make())
    with pytest.raises(FormatError, match=pattern) as err:
        merl.read_merl_arrays(path)
    assert str(path) in str(err.value)


def test_merl_extra_bytes_and_non_finite_values_name_the_byte(tmp_path):
    table = np.ones((3, RES_TH, RES_TD, RES_PD))
    path = tmp_path / "extra.binary"
    pack_merl(path, table)
    with open(path, "ab") as f:
        f.write(b"\0" * 8)
    with pytest.raises(FormatError, match=rf"extra data: it ends at byte {FILE_SIZE + 8}"):
        merl.read_merl_arrays(path)
    table[1, 2, 3, 4] = np.nan
    pack_merl(path, table)
    offset = HEADER + 8 * (((1 * RES_TH + 2) * RES_TD + 3) * RES_PD + 4)
    with pytest.raises(FormatError, match=rf"nan at byte {offset} is not finite"):
        merl.read_merl_arrays(path)


def test_merl_dimensions_in_another_order_are_accepted_as_by_the_reference(tmp_path, code_samples):
    # BRDFRead.cpp checks only the product of the dimensions; the layout is fixed
    path = tmp_path / "order.binary"
    pack_merl(path, code_table(), dims=(180, 90, 90))
    got = merl.read_merl_arrays(path)
    np.testing.assert_array_equal(got.values, code_samples.values)
    np.testing.assert_array_equal(got.wi, code_samples.wi)


def test_reading_a_full_merl_file_stays_well_under_a_gigabyte(ones_file):
    tracemalloc.start()
    try:
        data = merl.read_merl(ones_file)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    wi, _ = merl.grid_directions()
    assert data.n == len(wi) and data.n > 1_000_000
    np.testing.assert_allclose(data.values[:, 1], 1.15, rtol=1e-15)
    assert peak < 1e9, f"peak traced memory {peak / 1e6:.0f} MB"


# -------------------------------------------------------------------------- MBSDF
def test_real_mbsdf_file_has_its_documented_layout():
    path = shared_file("nvidia", "carpaint_red.mbsdf")
    raw = path.read_bytes()
    assert raw.startswith(MAGIC + REFLECTION)
    offset = len(MAGIC) + len(REFLECTION)
    kind, n_theta, n_phi = struct.unpack_from("<3I", raw, offset)
    count = n_theta * n_theta * n_phi * 3
    expected = np.array(struct.unpack_from(f"<{count}f", raw, offset + 12))
    with pytest.warns(UserWarning, match="negative"):
        data = read_mbsdf(path)
    s = read_mbsdf_arrays(path)
    assert (kind, s.theta_resolution, s.phi_resolution) == (1, 45, 90)
    assert data.channels == ("r", "g", "b") and data.n == 45 * 45 * 90
    assert s.has_transmission is False and s.metadata == {}
    np.testing.assert_array_equal(data.values.ravel(), expected)
    # small negative values (noise) are kept and counted, not dropped
    assert data.negative_count == (expected < 0).sum() > 0
    assert data.values.min() > -0.01 * data.values.max()


def test_real_mbsdf_directions_are_cell_centres_with_the_mirror_at_phi_i_plus_pi():
    path = shared_file("nvidia", "carpaint_red.mbsdf")
    with pytest.warns(UserWarning):
        data = read_mbsdf(path)
    ti, pi_, to, po = data.angles()
    np.testing.assert_allclose(pi_, 0.0, atol=1e-9)
    cells = np.arange(45)
    np.testing.assert_allclose(np.unique(ti.round(9)), (cells + 0.5) * 2.0, atol=1e-7)
    np.testing.assert_allclose(np.unique(po.round(9)), (np.arange(90) + 0.5) * 2.0, atol=1e-7)
    total = data.values.sum(axis=1).reshape(45, 45 * 90)
    for k in range(3, 45):  # below 7 degrees the azimuth of the peak means little
        peak = k * 45 * 90 + int(total[k].argmax())
        assert abs(po[peak] - 180.0) <= 10.0, (k, po[peak])
        if k <= 32:  # past 65 degrees the file repeats its 65-degree row
            assert abs(to[peak] - ti[peak]) <= 4.0, (k, to[peak], ti[peak])


@pytest.mark.parametrize("kind, channels", [(1, ("r", "g", "b")), (0, ("value",))])
def test_synthetic_mbsdf_is_read_back_exactly(tmp_path, kind, channels):
    n_theta, n_phi, c = 3, 4, len(channels)
    rng = np.random.default_rng(kind)
    values = rng.uniform(-0.1, 5.0, n_theta * n_theta * n_phi * c).astype(np.float32)
    meta = b'NAME="red \\"paint\\""\nAUTHOR=someone\n'
    blob = MAGIC + meta + REFLECTION + pack_block(kind, n_theta, n_phi, values.tolist())
    path = tmp_path / "synthetic.mbsdf"
    path.write_bytes(blob)
    s = read_mbsdf_arrays(path)
    assert s.channels == channels and s.metadata == {"NAME": 'red "paint"', "AUTHOR": "someone"}
    np.testing.assert_array_equal(s.values, values.reshape(-1, c).astype(float))
    with pytest.warns(UserWarning):
        data = read_mbsdf(path)
    ti, pi_, to, po = data.angles()
    n = 0
    for a in range(n_theta):
        for b in range(n_theta):
            for p in range(n_phi):
                expect = ((a + 0.5) * 90 / n_theta, 0.0, (b + 0.5) * 90 / n_theta)
                assert (ti[n], pi_[n] % 360, to[n]) == pytest.approx(expect, abs=1e-9)
                assert po[n] == pytest.approx((p + 0.5) * 180 / n_phi, abs=1e-9)
                n += 1


def test_mbsdf_transmission_part_is_checked_and_skipped(tmp_path):
    refl = pack_block(0, 2, 3, [1.0] * 12)
    trans = pack_block(1, 2, 3, [7.0] * 36)
    path = tmp_path / "both.mbsdf"
    path.write_bytes(MAGIC + b"MBSDF_DATA=\n" + refl + TRANSMISSION + trans)
    s = read_mbsdf_arrays(path)
    assert s.has_transmission and (s.values == 1.0).all() and s.values.shape == (12, 1)
    path.write_bytes(MAGIC + REFLECTION + refl + TRANSMISSION + trans[:-4])
    end = len(MAGIC + REFLECTION + refl + TRANSMISSION) + len(trans)
    with pytest.raises(FormatError, match=rf"transmission block.*reach byte {end}"):
        read_mbsdf_arrays(path)
    path.write_bytes(MAGIC + TRANSMISSION + trans)
    with pytest.raises(FormatError, match=rf"at byte {len(MAGIC)}, is a transmission"):
        read_mbsdf_arrays(path)


def _broken_cases():
    good = pack_block(1, 2, 2, [0.5] * 24)
    head = len(MAGIC) + len(REFLECTION)
    return [
        (b"NVIDIA ARC MBSDF V2\n" + REFLECTION + good, r"wrong magic at byte 0"),
        (MAGIC + REFLECTION + good[:8], rf"truncated.*12 bytes.*at byte {head}.*ends at byte"),
        (
            MAGIC + REFLECTION + good[:-1],
            (
                rf"truncated.*from byte {head + 12}.*reach byte {head + len(good)}, "
                rf"but it ends at byte {head + len(good) - 1}"
            ),
        ),
        (MAGIC + REFLECTION + struct.pack("<3I", 2, 2, 2), rf"type at byte {head} is 2"),
        (
            MAGIC + REFLECTION + struct.pack("<3I", 1, 0, 2),
            rf"theta resolution at byte {head + 4}",
        ),
        (MAGIC + REFLECTION + struct.pack("<3I", 1, 2, 0), rf"phi resolution at byte {head + 8}"),
        (
            MAGIC + REFLECTION + struct.pack("<3I", 1, 100000, 100000),
            r"truncated.*100000 x 100000",
        ),
        (MAGIC + b"NAME=x\n", rf"no data block.*from byte {len(MAGIC) + 7}"),
        (MAGIC + b"\xff\xfe\n" + REFLECTION + good, rf"line at byte {len(MAGIC)} is not text"),
        (MAGIC + REFLECTION + good + b"junk", rf"unexpected data at byte {head + len(good)}"),
    ]


@pytest.mark.parametrize("blob, pattern", _broken_cases())
def test_broken_mbsdf_files_name_the_file_and_the_byte(tmp_path, blob, pattern):
    path = tmp_path / "broken.mbsdf"
    path.write_bytes(blob)
    with pytest.raises(FormatError, match=pattern) as err:
        read_mbsdf_arrays(path)
    assert str(path) in str(err.value)


def test_non_finite_mbsdf_value_names_its_byte(tmp_path):
    values = [0.5] * 24
    values[5] = math.inf
    path = tmp_path / "inf.mbsdf"
    path.write_bytes(MAGIC + REFLECTION + pack_block(1, 2, 2, values))
    offset = len(MAGIC) + len(REFLECTION) + 12 + 4 * 5
    with pytest.raises(FormatError, match=rf"inf at byte {offset}"):
        read_mbsdf_arrays(path)
