"""Loading the compiled loops from numba's disk cache without numba's registries.

A first compiled fit in a process paid about 0.45 s of CPU before its loops ran
(``benchmarks/README.md``, "The first compiled fit in a process"): numba's import
(0.13 s), then, on the first load of a cached loop, numba's
``FunctionCache.load_overload``, which refreshes the CPU target's typing and
lowering registries before it reads the cached machine code: it imports some
seventy modules of numba (its typed containers, random generators, polynomials,
datetimes, cffi and pycparser) and, through ``numba.np.arraymath``'s check for a
BLAS, ``scipy.linalg`` (0.15-0.25 s; nothing else in a fit imports it), and
installs every registry's templates: 0.3-0.4 s of CPU in all. The registries serve
typing and lowering, i.e. compilation. A loop loaded from the cache is not
compiled: its machine code is read (``CompileResult._rebuild``: the object code
into numba's JIT, the entry point made callable), and it needs only what that code
links against: numba's C helpers (installed when the target context is made) and
numba's reference-counting runtime (NRT, whose ``initialize`` compiles its
functions with LLVM in every process, 15 ms). :class:`LightCache` loads the loops
that way: it initialises the NRT, its functions read from a file of their machine
code saved beside the loops' cache by the first process that compiled them
(:func:`_initialize_runtime`, 2 ms), and reads the cache, where numba's cache
refreshes the whole context first.

The cached machine code comes with the environments of the functions it holds
(their module's globals and constants), which numba's rebuild makes by importing
each function's module: those of numba's implementations linked in (``np.empty``:
``numba.np.arrayobj``, 15-25 ms of CPU) are made without the import
(:func:`_rebuild_environment`).

Before that, a dispatcher's first call ran numba's ``entrypoints.init_all``, which
reads the metadata of every installed distribution for numba extensions (0.02 s
with 160 distributions, more in larger environments). Extensions, too, serve
typing and lowering, and numba's refresh before a compilation initialises them
(``CPUContext.load_additional_registries``), so the loops' dispatchers skip that
call.

The machine code, and so every value, is the same (the tests compare a fit loaded
both ways bit for bit). A loop that is not in the cache (a fresh install, an
edited module) is compiled by numba as before, which refreshes the registries and
initialises the extensions itself (``CompilerBase``); so does any other numba code
in the process.

:func:`lighten` gives the dispatchers of a loop module both; numba's own cache
stays where the numba internals it relies on are missing (another numba
version), so the loops then load as before, only slower.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import re
import sys
import uuid

import llvmlite
import numba
from llvmlite import binding
from numba.core import caching, config, environment
from numba.core.dispatcher import Dispatcher

__all__ = ["LightCache", "lighten"]

#: What :class:`LightCache` relies on in numba (0.68.1 has them; checked here, as
#: the runtime is below, so that another numba keeps its own cache).
_NEEDED = ("_load_overload", "_guard_against_spurious_io_errors", "load_overload")


def _runtime():
    """numba's reference-counting runtime (``numba.core.runtime.rtsys``), or None in a
    numba that keeps it elsewhere."""
    try:
        from numba.core.runtime import rtsys
    except ImportError:
        return None
    return rtsys if callable(getattr(rtsys, "initialize", None)) else None


_RTSYS = _runtime()
#: The numba releases (major, minor) whose internals :class:`LightCache` was checked
#: against, by tests/models/test_kernels_cached.py: what it skips is private to numba
#: and may change meaning without changing name, so another release keeps numba's own
#: cache (every loop loads as before, 0.3 s slower on a first fit) until it is checked.
TESTED_RELEASES = ((0, 68),)


def _release(version: str) -> tuple:
    """``(major, minor)`` of a version string such as ``0.68.1`` or ``0.69.0rc1``: the
    leading digits of its first two parts, 0 where there are none (a source build's
    ``0+unknown`` is ``(0, 0)``, not a release checked, rather than an error that
    would switch the kernels off)."""
    parts = [*version.split("."), "0", "0"][:2]
    return tuple(int(re.match(r"\d*", part).group() or 0) for part in parts)


_USABLE = (
    _RTSYS is not None
    and hasattr(_RTSYS, "_init")
    and callable(getattr(environment, "_rebuild_env", None))
    and hasattr(environment, "lookup_environment")
    and all(hasattr(caching.FunctionCache, n) for n in _NEEDED)
    and _release(numba.__version__) in TESTED_RELEASES
)


class LightCache(caching.FunctionCache):
    """numba's cache of a function's machine code, loaded without the registries."""

    def load_overload(self, sig, target_context):
        """The cached compile result of ``sig``, or None (numba then compiles).

        numba's own method refreshes ``target_context`` first; here only the runtime
        the machine code links against is initialised (see the module's doc)."""
        _initialize_runtime(target_context, self.cache_path)
        with self._guard_against_spurious_io_errors(), _numbas_modules_unimported():
            return self._load_overload(sig, target_context)
        return None  # the guard swallowed an I/O error on Windows, as numba's own


#: Where the runtime's compiled functions came from in this process: None (not
#: initialised here, or by numba), "file" (:data:`RUNTIME_FILE`) or "compiled".
runtime_source = {"from": None}
#: The file, in the loops' cache folder, of the runtime's compiled functions.
RUNTIME_FILE = f"_cached.runtime.py{sys.version_info[0]}{sys.version_info[1]}.nbc"


def _initialize_runtime(target_context, folder: str) -> None:
    """numba's runtime initialised as ``rtsys.initialize`` does it, its few functions
    (reference counts, atomic operations) read from :data:`RUNTIME_FILE` in ``folder``
    where a process saved them for this numba, LLVM, Python and CPU, else compiled
    and saved there: numba compiles them with LLVM at every start (15 ms of CPU).
    The machine code is LLVM's for the same module, read back as numba reads a
    cached loop's (its object code and the bitcode later compilations link with).
    Where any of it fails, numba's own initialisation runs."""
    if _RTSYS._init:
        return
    try:
        from numba.core.runtime import _nrt_python, nrtdynmod

        if config.NRT_STATS:
            _nrt_python.memsys_enable_stats()
        for name, address in _nrt_python.c_helpers.items():
            binding.add_symbol(name if name.startswith("_") else f"NRT_{name}", address)
        codegen = target_context.codegen()
        key, path = _runtime_key(codegen), os.path.join(folder, RUNTIME_FILE)
        library = _read_runtime(codegen, path, key)
        runtime_source["from"] = "file" if library is not None else "compiled"
        if library is None:
            ir_module, library = nrtdynmod.create_nrt_module(target_context)
            library.enable_object_caching()
            library.add_ir_module(ir_module)
            library.finalize()
            _save_runtime(library, path, key)
        _RTSYS._library, _RTSYS._init = library, True
    except Exception:
        runtime_source["from"] = None
        _RTSYS.initialize(target_context)


def _runtime_key(codegen) -> tuple:
    """What the runtime's machine code depends on: numba, LLVM, Python, the CPU, and
    numba's NRT debug settings (``NUMBA_DEBUG_NRT`` compiles a print into every
    reference count: a file saved by a process debugging them printed on the standard
    output of every later process)."""
    key = (numba.__version__, llvmlite.__version__, sys.version_info[:2])
    debug = (bool(config.DEBUG_NRT), getattr(config, "DEBUG_NRT_STACK_LIMIT", None))
    return (*key, codegen.magic_tuple(), debug)


def _read_runtime(codegen, path: str, key: tuple):
    """The runtime's library from ``path`` if it was saved there under ``key``."""
    try:
        with open(path, "rb") as handle:
            saved, state = pickle.load(handle)
    except (OSError, EOFError, pickle.UnpicklingError, ValueError, TypeError):
        return None
    return codegen.unserialize_library(state) if saved == key else None


def _save_runtime(library, path: str, key: tuple) -> None:
    """Save the runtime's compiled ``library`` at ``path`` under ``key`` (replaced
    whole, as numba writes its cache; nothing where the folder is not writable)."""
    if library.has_dynamic_globals:  # addresses of this process: not reusable
        return
    data = pickle.dumps((key, library.serialize_using_object_code()), protocol=-1)
    temporary = f"{path}.tmp.{uuid.uuid4().hex[:16]}"  # as numba's _open_for_write
    try:
        with open(temporary, "wb") as out:
            out.write(data)
        os.replace(temporary, path)
    except OSError:
        with contextlib.suppress(OSError):
            os.remove(temporary)


#: numba's own rebuild of a function's environment (see :func:`_rebuild_environment`).
_REBUILD = getattr(environment, "_rebuild_env", None)


def _rebuild_environment(modname, consts, env_name):
    """A cached function's environment, as numba's ``_rebuild_env`` makes it, but
    for a function of numba's own implementation modules not yet imported.

    numba's rebuild imports the module the function was defined in, for the
    environment's globals: a loop that allocates (``np.empty``) links numba's
    implementation of it, and its environment imported ``numba.np.arrayobj``
    (15-25 ms of CPU, with numba's strings and ``numpy.ma``). An environment's
    globals serve only code compiled in object mode, which numba's implementations
    never are (they are overloads and intrinsics, compiled in nopython mode); their
    environments get the module's name as globals and the cached constants, and
    numba's own rebuild stays for every other module (the loops' own)."""
    if modname in sys.modules or not modname.startswith("numba."):
        return _REBUILD(modname, consts, env_name)
    env = environment.lookup_environment(env_name)
    if env is None:
        env = environment.Environment({"__name__": modname})
        env.consts[:] = consts
        env.env_name = env_name
        environment.Environment._memo[env_name] = env
    return env


@contextlib.contextmanager
def _numbas_modules_unimported():
    """While a cached loop loads (numba's compiler lock held by its dispatcher):
    its pickle rebuilds environments by :func:`_rebuild_environment`."""
    environment._rebuild_env = _rebuild_environment
    try:
        yield
    finally:
        environment._rebuild_env = _REBUILD


def _no_extensions() -> None:
    """A dispatcher's compilation-chain hook that leaves numba's extensions to the
    refresh before a compilation (see the module's doc)."""


def lighten(module) -> int:
    """Give each dispatcher of ``module`` that caches on disk :class:`LightCache`
    (once; its cache's state is kept: only the class of the cache object changes)
    and a first call without numba's scan for extensions: the module's dispatchers
    and those its functions wrap (``__wrapped__``). Returns how many have them."""
    if not _USABLE:
        return 0
    found = {}
    for value in vars(module).values():
        # a dispatcher, or a function wrapping one (loops_microfacet.wide)
        for candidate in (value, getattr(value, "__wrapped__", None)):
            if isinstance(candidate, Dispatcher):
                found[id(candidate)] = candidate
    count = 0
    for dispatcher in found.values():
        cache = getattr(dispatcher, "_cache", None)
        if type(cache) is caching.FunctionCache:
            cache.__class__ = LightCache  # the same object: a subclass, no new state
            if hasattr(dispatcher, "_compilation_chain_init_hook"):
                dispatcher._compilation_chain_init_hook = _no_extensions
        count += isinstance(cache, LightCache)
    return count
