"""Regenerate data_synthetic/: one CSV per registered model, and truth.json.

    python data_synthetic/generate.py            # into data_synthetic/
    python data_synthetic/generate.py --out DIR  # elsewhere (the tests compare)

Every model of ``brdffit.models.REGISTRY`` at the time of the run gets a file
``<model>.csv``: the model evaluated with the parameters of :data:`PARAMS`
(or, for a model without an entry, its defaults; the run says so), on a
gonioreflectometer grid (anisotropic models with three incidence azimuths, so
that the anisotropy is seen) or on random pairs over the hemisphere, with 1 %
relative Gaussian noise and the noise sigma in ``sigma_<channel>`` columns.
Linear parameters given per channel make RGB files; scalars make a ``value``
channel.

The output is the same bytes on every run: seeds come from the model name
(CRC-32), hemisphere angles are rounded to 1e-4 degrees before the model is
evaluated, and values and sigma are rounded to 8 significant digits (far below
the 1 % noise) so that the last bits of a platform's libm cannot show.
"""

from __future__ import annotations

import argparse
import json
import sys
import zlib
from pathlib import Path

import numpy as np

from brdffit.data.measurements import Measurements
from brdffit.io.csv_format import write_csv
from brdffit.models import REGISTRY
from brdffit.synth import GONIO_DEFAULTS, hemisphere_angles, synthesize

NOISE = 0.01
NOISE_KIND = "relative"
DIGITS = 8
HERE = Path(__file__).resolve().parent

RED, GREEN, BLUE, WHITE = [0.5, 0.12, 0.08], [0.15, 0.4, 0.12], [0.08, 0.15, 0.45], [1.0] * 3


def _grey(x: float) -> list:
    return [x, x, x]


#: Parameters of each model: realistic materials (paints, plastics, brushed
#: metals). Per-channel lists make RGB files; scalars a single ``value`` channel.
#: An optional "geometry" entry replaces the gonio grid by n random pairs.
PARAMS = {
    "lambert": {"params": {"kd": [0.6, 0.35, 0.2]}, "geometry": ("hemisphere", 600)},
    "phong": {"params": {"kd": 0.4, "ks": 0.8, "n": 40.0}},
    "phong_normalized": {"params": {"kd": RED, "ks": _grey(0.3), "n": 80.0}},
    "blinn": {"params": {"kd": RED, "ks": _grey(0.9), "n": 60.0}},
    "blinn_normalized": {"params": {"kd": BLUE, "ks": _grey(0.4), "n": 120.0}},
    "schlick": {"params": {"kd": [0.3, 0.3, 0.1], "ks": _grey(1.2), "n": 30.0}},
    "romanyuk": {"params": {"kd": GREEN, "ks": _grey(0.8), "n": 50.0}},
    "gaussian": {"params": {"kd": 0.35, "ks": 1.5, "n": 70.0}},
    "blake": {"params": {"kd": [0.5, 0.3, 0.3], "ks": _grey(0.7), "n": 25.0}},
    "lafortune": {"params": {"kd": [0.4, 0.25, 0.1], "ks": _grey(1.5), "cxy": -0.9, "n": 30.0}},
    "oren_nayar": {
        "params": {"kd": [0.7, 0.5, 0.3], "sigma": 0.35},
        "geometry": ("hemisphere", 600),
    },
    "ward": {"params": {"kd": [0.3, 0.08, 0.05], "ks": _grey(0.08), "alpha": 0.12}},
    "torrance_sparrow": {"params": {"kd": 0.4, "ks": 10.0, "m": 0.15, "eta": 1.5}},
    "cook_torrance": {"params": {"kd": [0.35, 0.15, 0.1], "ks": WHITE, "m": 0.2, "eta": 1.5}},
    "cook_torrance_schlick": {"params": {"kd": BLUE, "ks": WHITE, "m": 0.15, "f0": 0.05}},
    "ggx": {"params": {"kd": RED, "ks": WHITE, "alpha": 0.2, "f0": 0.04}},
    "beckmann": {"params": {"kd": GREEN, "ks": WHITE, "alpha": 0.15, "f0": 0.05}},
    "ward_anisotropic": {
        "params": {
            "kd": [0.1, 0.08, 0.05],
            "ks": [0.25, 0.2, 0.12],
            "alpha_x": 0.08,
            "alpha_y": 0.25,
        }
    },
    "ashikhmin_shirley": {
        "params": {"rd": [0.4, 0.2, 0.1], "rs": _grey(0.05), "nu": 200.0, "nv": 20.0}
    },
    "ashikhmin_phong": {
        "params": {"kd": [0.3, 0.3, 0.5], "ks": _grey(0.5), "nu": 150.0, "nv": 15.0}
    },
    "heidrich_seidel": {"params": {"kd": 0.3, "ks": 0.6, "n": 40.0}},
    "ohara": {"params": {"kd": [0.4, 0.2, 0.2], "ks": _grey(0.6), "a": 1.0, "b": 0.4, "n": 60.0}},
    "wang": {"params": {"kd": [0.2, 0.3, 0.4], "ks": _grey(0.7), "m": 150.0, "zeta": 20.0}},
    "fournier": {"params": {"kd": 0.3, "ks": 0.8, "n": 80.0, "t": 0.4}},
    "ggx_anisotropic": {
        "params": {
            "kd": _grey(0.02),
            "ks": [0.95, 0.64, 0.54],
            "alpha_u": 0.1,
            "alpha_v": 0.3,
            "f0": 0.9,
        }
    },
    "beckmann_anisotropic": {
        "params": {
            "kd": _grey(0.03),
            "ks": [0.91, 0.92, 0.92],
            "alpha_u": 0.3,
            "alpha_v": 0.08,
            "f0": 0.9,
        }
    },
    "gltf_pbr": {"params": {"base_color": RED, "metallic": 0.25, "roughness": 0.4}},
    "gltf_pbr_anisotropic": {
        "params": {
            "base_color": [0.95, 0.64, 0.54],
            "metallic": 0.9,
            "roughness": 0.35,
            "anisotropy_strength": 0.6,
            "anisotropy_rotation": 0.4,
        }
    },
    "mitsuba_roughconductor": {
        "params": {"specular_reflectance": [0.95, 0.64, 0.54], "alpha": 0.15}
    },
    "mitsuba_roughconductor_anisotropic": {
        "params": {"specular_reflectance": [0.91, 0.92, 0.92], "alpha_u": 0.08, "alpha_v": 0.25}
    },
    "mitsuba_roughplastic": {
        "params": {"diffuse": [0.6, 0.15, 0.1], "specular_reflectance": WHITE, "alpha": 0.12}
    },
    "mitsuba_principled": {"params": {"base_color": BLUE, "metallic": 0.2, "roughness": 0.35}},
    "mitsuba_principled_anisotropic": {
        "params": {
            "base_color": [0.9, 0.7, 0.4],
            "metallic": 0.85,
            "roughness": 0.4,
            "anisotropic": 0.6,
        }
    },
    # Wave optics: four wavelengths (channels named 400nm...), the material
    # constants eta, k and the aperture at the model's defaults (held in fits).
    "he": {
        "params": {
            "a_ud": [0.05, 0.05, 0.05, 0.05],
            "sigma0": 0.12,
            "tau": 1.5,
            "wavelength": [400.0, 500.0, 600.0, 700.0],
        }
    },
}


def _round(a: np.ndarray, digits: int = DIGITS) -> np.ndarray:
    """Round to ``digits`` significant digits (exactly what '%.{digits}g' prints)."""
    return np.array([float(f"{x:.{digits}g}") for x in np.ravel(a)]).reshape(np.shape(a))


def _as_json(value):
    return np.asarray(value).tolist()


def make(name: str, seed: int) -> tuple:
    """The Measurements of one model and its entry of truth.json."""
    model = REGISTRY[name]
    entry = PARAMS.get(name)
    if entry is None:
        print(f"{name}: no entry in PARAMS; using the model defaults", file=sys.stderr)
        entry = {"params": model.defaults()}
    params = {**model.defaults(), **entry["params"]}
    kind, n = entry.get("geometry", ("gonio", None))
    if kind == "hemisphere":
        # A stream of its own, so that the angles and the noise are independent draws.
        angles = hemisphere_angles(n, np.random.default_rng([seed, 1]))
        geometry = tuple(np.round(a, 4) for a in angles)
        described = {"name": "hemisphere", "n": n}
    else:
        geometry = "gonio"
        symmetry = model.classification.symmetry
        described = {"name": "gonio", "symmetry": symmetry, **GONIO_DEFAULTS[symmetry]}
    data = synthesize(model, params, geometry=geometry, noise=NOISE, noise_kind=NOISE_KIND,
                      seed=seed)  # fmt: skip
    data = Measurements.from_angles(*data.angles(), _round(data.values), channels=data.channels,
                                    sigma=_round(data.sigma), source=data.source)  # fmt: skip
    truth = {
        "model": name,
        "params": {k: _as_json(v) for k, v in params.items()},
        "params_from": "PARAMS table" if name in PARAMS else "model defaults",
        "noise": NOISE,
        "noise_kind": NOISE_KIND,
        "seed": seed,
        "geometry": described,
        "channels": list(data.channels),
        "n": data.n,
        "rounding": f"values and sigma to {DIGITS} significant digits",
    }
    return data, truth


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="output directory")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    truth = {}
    for name in sorted(REGISTRY):
        seed = zlib.crc32(name.encode())
        data, truth[f"{name}.csv"] = make(name, seed)
        write_csv(args.out / f"{name}.csv", data)
    text = json.dumps({"generator": "python data_synthetic/generate.py", "files": truth},
                      indent=2, sort_keys=True)  # fmt: skip
    (args.out / "truth.json").write_text(text + "\n", encoding="utf-8")
    print(f"wrote {len(truth)} files and truth.json to {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
