"""The fitting problems shared by the fit benchmarks: the data_synthetic/ suite,
the Cornell files in ../shared/data, and seeded random truths (harder starts).

Success is judged the same way everywhere:
- a problem with a known truth succeeds when every parameter is within 3 % of it,
  or, failing that, the fitted BRDF is within 1 % of the true one over the
  hemisphere (weakly identifiable parameters, e.g. ohara's a, b, n);
- a real file succeeds when its loss is within 1e-4 (relative) of the best loss
  any method found for it in the same run.
"""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from helpers import (  # noqa: E402
    hemisphere_pairs,
    make_data,
    random_params,
)

import brdffit  # noqa: E402
from brdffit.models import REGISTRY  # noqa: E402

CORNELL = ROOT.parent / "shared" / "data" / "cornell"
CORNELL_FILES = ["garnet_red.astm", "krylon_blue.astm", "acryl_blue.brdf"]
CORNELL_MODELS = ["blinn", "ward", "cook_torrance", "ashikhmin_shirley"]


@dataclass
class Case:
    label: str
    data: object
    model: str
    truth: dict | None


def synthetic_cases() -> list[Case]:
    truth = json.loads((ROOT / "data_synthetic" / "truth.json").read_text())["files"]
    return [
        Case(
            f"synthetic/{name}",
            brdffit.read(ROOT / "data_synthetic" / name),
            e["model"],
            e["params"],
        )
        for name, e in sorted(truth.items())
    ]


def cornell_cases(models=CORNELL_MODELS) -> list[Case]:
    if not CORNELL.exists():
        print(f"# {CORNELL} is absent: Cornell cases skipped", file=sys.stderr)
        return []
    out = []
    for f in CORNELL_FILES:
        data = brdffit.read(CORNELL / f)
        out += [Case(f"cornell/{f}/{m}", data, m, None) for m in models]
    return out


def random_cases(per_model: int = 3, seed: int = 5) -> list[Case]:
    """Noiseless data from random truths anywhere in the parameter box."""
    rng = np.random.default_rng(seed)
    out = []
    for name in sorted(REGISTRY):
        model = REGISTRY[name]
        if any(p.per_channel for p in model.params):
            continue
        for k in range(per_model):
            truth = random_params(model, rng)
            out.append(
                Case(
                    f"random/{name}/{k}",
                    make_data(name, truth, n=800, noise=0.0, seed=k),
                    name,
                    truth,
                )
            )
    return out


def recovered(case: Case, params) -> bool:
    model = brdffit.get_model(case.model)
    ok = True
    for p in model.params:
        t = np.asarray(case.truth[p.name], dtype=float)
        f = np.asarray(params[p.name], dtype=float)
        if np.any(np.abs(f - t) > 0.03 * np.maximum(np.abs(t), 1e-9)):
            ok = False
    if ok:
        return True
    wi, wo = hemisphere_pairs(20000, seed=9, grazing=False)
    f_true = np.asarray(model.evaluate(wi, wo, case.truth))
    f_fit = np.asarray(model.evaluate(wi, wo, dict(params)))
    return bool(np.max(np.abs(f_fit - f_true)) <= 0.01 * np.max(f_true))


def machine() -> str:
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{cpu}, {os.cpu_count()} cores, numpy {np.__version__}, Python {sys.version.split()[0]}"
    )
