"""``largest`` and ``smallest``: Python's ``max`` and ``min`` of numbers for numba kernels,
compiled in place.

numba's own ``max``/``min`` are overloads: every distinct pair of argument types and calling
kernel's compile options (a kernel, a device helper, a parallel kernel, a frame function)
compiles a small function of its own, about 20 ms each; the walk bake's cold start compiled 22
of them. These are intrinsics that emit numba's own code for them (``do_minmax``: the
arguments unified to one type, then compared and selected pairwise, left to right, the way
Python does it: ``max(a, b)`` is ``b if b > a else a``, so NaNs and signed zeros come out as
they did) straight into the caller: same machine code, nothing compiled separately.
"""

from __future__ import annotations

import operator

import numba
from numba.core import cgutils, types
from numba.cpython.builtins import do_minmax
from numba.extending import intrinsic


def _extreme(compare):
    def typer(typingctx, *values):
        if not values or not all(isinstance(v, (types.Number, types.Boolean)) for v in values):
            return None
        common = typingctx.unify_types(*values)
        if common is None:
            return None

        def codegen(context, builder, signature, args):
            return do_minmax(context, builder, list(signature.args[0]), cgutils.unpack_tuple(builder, args[0]), compare)

        return common(types.StarArgTuple.from_types(values)), codegen

    return intrinsic(typer)


largest = _extreme(operator.gt)
largest.__doc__ = "max(*values) of numbers, in a kernel."
smallest = _extreme(operator.lt)
smallest.__doc__ = "min(*values) of numbers, in a kernel."

if numba.config.DISABLE_JIT:  # type: ignore[attr-defined]  # set dynamically by numba
    # NUMBA_DISABLE_JIT=1 runs the kernels as plain Python: Python's own, which these copy
    largest, smallest = max, min  # type: ignore[assignment]
