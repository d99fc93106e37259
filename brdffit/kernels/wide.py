"""512-bit vectors for the compiled loops bound by arithmetic: :func:`prefer_wide_vectors`.

LLVM vectorises numba's loops for the host CPU, but on the x86 CPUs with AVX-512
it prefers 256-bit vectors (four float64 lanes) by default: 512-bit instructions
lower the clock of some older cores (Skylake server parts), which costs code that
is bound by memory and not by arithmetic. The loops of
:mod:`brdffit.kernels.loops_empirical` are bound by arithmetic (a ``log`` and an
``exp`` per pair, about 60 vector instructions per four pairs, the same throughput in
the cache and streamed from memory): on the machine of ``benchmarks/`` (Intel Xeon,
AVX-512) they run 25 to 72 % faster with eight lanes (gaussian 72 %, wang 36 %,
fournier 29 %, ohara 26 %, lafortune 25 %: each loop with and without the attribute,
interleaved in one run at load 2.7, on the 1M pairs of ``bench_evaluate.py``).
A function that calls :func:`prefer_wide_vectors` gets the LLVM
function attribute ``"prefer-vector-width"="512"`` (the attribute clang's
``-mprefer-vector-width=512`` sets): on CPUs without AVX-512 it changes nothing.

The attribute is set through llvmlite's function attributes, which list only the
attributes llvmlite knows. An llvmlite that refused it when it is added, or only
later, when numba prints the module (as llvmlite's own ``add`` checks names) or
LLVM parses it, would make the loop's compilation raise, and with it the model's
evaluation: so the attribute is first tried once on a function of its own
(:func:`_accepted`), and where that fails no loop gets it and the loops compile as
before, with the default width.
"""

from __future__ import annotations

import functools

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["prefer_wide_vectors"]

_ATTRIBUTE = '"prefer-vector-width"="512"'


def _add(attributes) -> None:
    # set.add: llvmlite's own add() accepts only the attributes it knows
    set.add(attributes, _ATTRIBUTE)


@functools.cache
def _accepted() -> bool:
    """Whether this llvmlite prints the attribute and LLVM parses it back: tried once
    on an empty function of its own module (see the module docstring)."""
    try:
        import llvmlite.binding as llvm

        module = ir.Module(name="prefer_wide_vectors_probe")
        function = ir.Function(module, ir.FunctionType(ir.VoidType(), ()), name="probe")
        _add(function.attributes)
        ir.IRBuilder(function.append_basic_block()).ret_void()
        parsed = llvm.parse_assembly(str(module))
        parsed.verify()
        return "prefer-vector-width" in str(parsed)
    except Exception:  # refused somewhere: the loops keep the default width
        return False


@intrinsic
def prefer_wide_vectors(typingctx):
    """Mark the calling compiled function for 512-bit vectors (see the module)."""

    def codegen(context, builder, signature, args):
        if _accepted():
            _add(builder.function.attributes)
        return context.get_dummy_value()

    return types.none(), codegen
