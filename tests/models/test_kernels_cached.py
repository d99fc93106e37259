"""Loading the compiled loops from numba's disk cache (brdffit.kernels._cached).

A first compiled fit in a process paid numba's refresh of its CPU target's
registries (some seventy modules of numba and scipy.linalg, 0.3-0.4 s of CPU) on
its first load of a cached loop; the loops now load without it. These tests hold
that a fit loads its loops that way (a large table's fit too, whose loops must not
link numba's array maths), that the fit is the same bit for bit as with numba's
own load, that numba compiles new code in that process as before, and that a fit's
calls give each loop one signature to load.
"""

from __future__ import annotations

import json
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from helpers import NEEDS_KERNELS, hemisphere_pairs

from brdffit import kernels
from brdffit.fitting import sums
from brdffit.fitting.losses import LossContext

pytestmark = NEEDS_KERNELS
numba = pytest.importorskip("numba", reason="numba is not installed: no compiled kernels")


def _usable() -> bool:
    from brdffit.kernels import _cached

    return _cached._USABLE


#: For the tests of the light load itself: a numba without the internals it relies on
#: keeps numba's own cache (the tests of the signatures hold either way).
NEEDS_LIGHT = pytest.mark.skipif(
    kernels.available() and not _usable(),
    reason=f"numba {numba.__version__} is not a release brdffit's light cache load was "
    "checked against (kernels._cached.TESTED_RELEASES), or lacks the internals it uses",
)

ROOT = Path(__file__).resolve().parents[2]

#: A compiled ward fit in a fresh interpreter (``prelude`` first); prints what it
#: loaded and how, and the fit's parameters and loss as exact hexadecimal floats.
FIT = """
import json, sys
import numpy as np
import brdffit
from brdffit import kernels
{prelude}
with kernels.use(True):
    r = brdffit.fit({data}, {model!r}, loss='l2')
from numba.core.dispatcher import Dispatcher
loaded = {{}}
for name, module in list(sys.modules.items()):
    if name.startswith('brdffit.kernels.'):
        for key, value in vars(module).items():
            if isinstance(value, Dispatcher) and value.signatures:
                stats = value.stats
                loaded[key] = [len(value.signatures), sum(stats.cache_hits.values()),
                               sum(stats.cache_misses.values()), type(value._cache).__name__]
heavy = [m for m in ('numba.np.arraymath', 'numba.np.arrayobj', 'numba.typed.typeddict',
                     'scipy.linalg') if m in sys.modules]
fit = [float(v).hex() for v in np.concatenate(
    [np.atleast_1d(r.params[k]) for k in sorted(r.params)] + [[r.loss]])]
from numba.core import entrypoints
from brdffit.kernels import _cached
print(json.dumps({{'loaded': loaded, 'heavy': heavy, 'fit': fit,
                  'extensions': entrypoints._already_initialized,
                  'runtime': _cached.runtime_source['from']}}))
"""

#: numba's own compilation in the same process afterwards: np.dot (BLAS through
#: scipy.linalg) and an allocation (numba's array registries).
COMPILE_AFTER = """
import numba
@numba.njit
def product(a, b):
    out = np.empty(a.shape[0])
    out[:] = np.dot(a, b)
    return out
a, b = np.arange(12.0).reshape(4, 3), np.array([0.5, -1.0, 2.0])
assert np.array_equal(product(a, b), a @ b)
print(json.dumps(['scipy.linalg' in sys.modules, entrypoints._already_initialized]))
"""


#: The ward fit's data (a random geometry: the misfit test sorts it by numpy).
WARD = "brdffit.read('data_synthetic/ward.csv')"
#: A sixteenth of a MERL table, 68,514 pairs: above ``coarse_above``, so the fit takes
#: the coarse-to-fine schedule (its compiled stratified draw), and a table's few
#: distinct angles, so the misfit test sorts by counting (kernels/loops_runs.py).
MERL_PART = (
    "brdffit.synthesize('cook_torrance', {'kd': [0.12, 0.08, 0.05], 'ks': [0.9, 0.7, "
    "0.5], 'm': 0.15, 'eta': 1.6}, geometry='merl', noise=0.01, seed=7).subset("
    "np.arange(0, 1096216, 16))"
)


def _run(prelude: str = "", after: str = "", data: str = WARD, model: str = "ward") -> list:
    """The JSON lines the fit (and ``after``) print in a fresh interpreter."""
    code = FIT.format(prelude=prelude, data=data, model=model) + after
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, check=False
    )
    assert out.returncode == 0, out.stderr
    return [json.loads(line) for line in out.stdout.strip().splitlines()[-2 if after else -1 :]]


@pytest.fixture(scope="module")
def light_and_numbas():
    """The fit loaded by brdffit's cache (numba compiling afterwards) and by numba's
    own (its registries refreshed on the first load), each in a fresh interpreter;
    a first run fills the disk cache where it is empty (a fresh clone)."""
    _run()
    light, compiled_after = _run(after=COMPILE_AFTER)
    (numbas,) = _run(prelude="from brdffit.kernels import _cached; _cached._USABLE = False")
    return light, compiled_after, numbas


@NEEDS_LIGHT
def test_a_fit_loads_its_cached_loops_without_numbas_registries(light_and_numbas):
    light, _, numbas = light_and_numbas
    assert light["loaded"], "the fit ran no compiled loop"
    for name, (signatures, hits, misses, cache) in light["loaded"].items():
        assert (signatures, hits, misses, cache) == (1, 1, 0, "LightCache"), name
    assert light["heavy"] == [] and light["extensions"] is False
    assert light["runtime"] == "file"  # numba's runtime as the first run saved it
    # the control: numba's own load refreshes the registries (scipy.linalg with them)
    # and reads the distributions' metadata for numba extensions
    assert {cache for *_, cache in numbas["loaded"].values()} == {"FunctionCache"}
    assert "numba.np.arraymath" in numbas["heavy"] and numbas["extensions"] is True
    assert numbas["runtime"] is None


@NEEDS_LIGHT
def test_a_table_fit_loads_its_loops_without_numbas_array_maths():
    """The loops of a large table's fit (the schedule's draw, the misfit test's
    counting sorts) load without ``numba.np.arraymath``, whose import imports
    ``scipy.linalg`` (0.11 s of CPU of a first MERL fit): a loop calling ``np.max``
    links numba's implementation, whose environment the cache load imports."""
    _run(data=MERL_PART, model="ggx")  # the disk cache filled where it is empty
    light, compiled_after = _run(data=MERL_PART, model="ggx", after=COMPILE_AFTER)
    assert {"draw", "order_by_ranks", "sign_codes_every"} <= set(light["loaded"])
    for name, (signatures, hits, misses, cache) in light["loaded"].items():
        assert (hits, misses, cache) == (signatures, 0, "LightCache"), name
    assert light["heavy"] == []
    # numba compiles an allocation afterwards, whose environment of np.empty's
    # implementation the loops' load made without importing numba.np.arrayobj
    assert compiled_after == [True, True]


@NEEDS_LIGHT
def test_the_fit_is_the_same_bit_for_bit_loaded_either_way(light_and_numbas):
    light, _, numbas = light_and_numbas
    assert sorted(light["loaded"]) == sorted(numbas["loaded"])
    assert light["fit"] == numbas["fit"]


@NEEDS_LIGHT
def test_numba_compiles_new_code_in_the_process_afterwards(light_and_numbas):
    """np.dot needs scipy.linalg's BLAS: numba imports it when it compiles np.dot,
    and initialises the extensions before it compiles."""
    _, compiled_after, _ = light_and_numbas
    assert compiled_after == [True, True]


@NEEDS_LIGHT
def test_the_runtime_file_is_read_only_where_it_was_saved_for_this_numba(tmp_path):
    """A runtime file of another numba, LLVM, Python or CPU (another key), or not one
    at all, is not read: the runtime is then compiled, as numba does."""
    import pickle

    from numba.core.registry import cpu_target

    from brdffit.kernels import _cached

    codegen, path = cpu_target.target_context.codegen(), tmp_path / _cached.RUNTIME_FILE
    assert _cached._read_runtime(codegen, str(path), ("key",)) is None  # no file
    path.write_bytes(b"not a pickle")
    assert _cached._read_runtime(codegen, str(path), ("key",)) is None
    path.write_bytes(pickle.dumps((("other key",), ("nrt", "object", (b"", b"")))))
    assert _cached._read_runtime(codegen, str(path), ("key",)) is None


@NEEDS_LIGHT
def test_a_runtime_file_saved_while_debugging_numbas_counts_is_not_read(tmp_path, monkeypatch):
    """``NUMBA_DEBUG_NRT`` compiles a print into every reference count: a runtime file
    saved by such a process, read by the next ones, printed ``*** NRT_Incref`` lines on
    their standard output (a CLI's JSON among them). Its key holds the setting."""
    from numba.core import config
    from numba.core.registry import cpu_target

    from brdffit.kernels import _cached

    codegen, path = cpu_target.target_context.codegen(), str(tmp_path / _cached.RUNTIME_FILE)
    monkeypatch.setattr(config, "DEBUG_NRT", 1)
    debugging = _cached._runtime_key(codegen)
    (tmp_path / _cached.RUNTIME_FILE).write_bytes(_pickle_of(debugging))
    monkeypatch.setattr(config, "DEBUG_NRT", 0)
    assert _cached._runtime_key(codegen) != debugging
    assert _cached._read_runtime(codegen, path, _cached._runtime_key(codegen)) is None


def _pickle_of(key) -> bytes:
    """A runtime file's bytes under ``key`` (its library never read: the key differs)."""
    import pickle

    return pickle.dumps((key, ("nrt", "object", (b"", b""))))


@NEEDS_LIGHT
def test_only_a_checked_numba_release_loads_light():
    """The light load is for the numba releases it was checked against; a version
    string's release is its major and minor number, whatever follows."""
    from brdffit.kernels import _cached

    assert _cached._release("0.68.1") == (0, 68)
    assert _cached._release("0.69.0rc1") == (0, 69)
    assert _cached._release("1.0") == (1, 0)
    assert _cached._release("0.68rc1") == (0, 68)
    assert _cached._release("0+unknown") == (0, 0)  # a source build: not checked
    checked = _cached._release(numba.__version__) in _cached.TESTED_RELEASES
    assert checked or not _cached._USABLE


def test_lighten_changes_only_disk_cached_dispatchers():
    from brdffit.kernels import _cached

    def square(x):
        return x * x

    def cube(x):
        return x * x * x

    def wrapper(x):
        return wrapper.__wrapped__(x)

    module = types.ModuleType("scratch")
    module.cached = numba.njit(cache=True)(square)
    module.plain = numba.njit(square)
    module.other = square
    wrapper.__wrapped__ = numba.njit(cache=True)(cube)  # as loops_microfacet.wide's
    module.wrapped = wrapper
    assert _cached.lighten(module) == 2
    for cached in (module.cached, wrapper.__wrapped__):
        assert type(cached._cache) is _cached.LightCache
        assert cached._compilation_chain_init_hook is _cached._no_extensions
    assert type(module.plain._cache).__name__ == "NullCache"
    assert module.plain._compilation_chain_init_hook is not _cached._no_extensions
    assert _cached.lighten(module) == 2  # once
    assert module.cached(3.0) == 9.0 and module.wrapped(2.0) == 8.0


def test_a_metrics_pass_gives_its_loop_one_layout(monkeypatch):
    """The last, shorter block of the compiled sums was a strided view ('A' layout):
    a second signature to load on a whole MERL file. Now every block is contiguous."""
    from brdffit.kernels import loops_sums

    monkeypatch.setattr(sums, "BLOCK", 1000)
    rng = np.random.default_rng(0)
    y = rng.uniform(0.1, 1.0, (2500, 3))
    ctx = LossContext(cos_i=rng.uniform(0.1, 1.0, 2500), y=y, sigma=None, weights=None)
    with kernels.use(True):
        totals = sums.loss_sums(y * 1.01, ctx)
    with kernels.use(False):
        expected = sums.loss_sums(y * 1.01, ctx)
    assert totals == pytest.approx(expected, rel=1e-12)
    buffers = {sig[8:12] for sig in loops_sums.sums_and_project.signatures}
    assert {a.layout for sig in buffers for a in sig} == {"C"}


def test_a_per_channel_evaluation_loads_one_signature():
    """``kd`` per channel with a shared ``ks`` and both per channel made a writable
    and a read-only scale: two signatures of the same loop."""
    from brdffit.kernels import loops
    from brdffit.models import get_model

    wi, wo = hemisphere_pairs(200, seed=1)
    model, shape = get_model("ward"), {"alpha": 0.2}
    with kernels.use(True):
        for kd, ks in [([0.1, 0.2, 0.3], 0.5), ([0.1, 0.2, 0.3], [0.5, 0.4, 0.3])]:
            model.evaluate(wi, wo, {"kd": np.array(kd), "ks": np.array(ks), **shape})
    assert len(loops.affine_by_channel.signatures) == 1


def test_a_failing_light_load_leaves_the_kernels_on(monkeypatch):
    """The light load only saves time: where it fails (another numba's internals), the
    loops load numba's way and the kernels stay on, without a warning that they are
    off. (It ran inside the import's try: a failure switched every kernel off.)"""
    import warnings

    from brdffit.kernels import _cached

    def broken(module):
        raise AttributeError("a numba without these internals")

    monkeypatch.setattr(_cached, "lighten", broken)
    monkeypatch.setitem(kernels._state, "loaded", {})
    monkeypatch.setitem(kernels._state, "lightened", set())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert kernels.wanted(10**6)
    assert kernels._state["loaded"] == {"loops": True}
