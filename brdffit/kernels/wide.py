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
attributes llvmlite knows; if a future llvmlite refuses it, the loop compiles as
before, with the default width.
"""

from __future__ import annotations

from numba import types
from numba.extending import intrinsic

__all__ = ["prefer_wide_vectors"]

_ATTRIBUTE = '"prefer-vector-width"="512"'


@intrinsic
def prefer_wide_vectors(typingctx):
    """Mark the calling compiled function for 512-bit vectors (see the module)."""

    def codegen(context, builder, signature, args):
        attributes = builder.function.attributes
        try:
            # set.add: llvmlite's own add() accepts only the attributes it knows
            set.add(attributes, _ATTRIBUTE)
        except Exception:  # an llvmlite that stores them otherwise
            pass
        return context.get_dummy_value()

    return types.none(), codegen
