"""``call_kernel(callees, slot, kernel, (args...))``: call a compiled kernel from compiled code
through a table of addresses, without linking it in.

A numba function that calls another one links the callee's code into its own and compiles
it again to machine code: a frame function calling every stage kernel would pay the
kernels' code generation a second time (seconds for the collision kernels). Here the call
goes to the callee's already compiled machine code (what the stage-by-stage path runs), at
the address the caller finds in row ``slot`` of ``callees``, a uint64 (slots, 2) table:
the address and a token of the callee and its argument types (``callee_token``).

The caller's code therefore names no symbol of another compiled function: it can be saved
to and loaded from numba's disk cache like any kernel, whichever process compiled its
callees under whatever symbols (numba numbers a function's symbol by the order of
compilation in a process). Each process fills the table with its own addresses
(clothtool.solver.framefn.compile_for). The token guards the table: a row that holds
another callee, or the same one for other argument types, raises instead of jumping into
code that reads its arguments wrongly.
"""

from __future__ import annotations

import hashlib

from llvmlite import ir
from numba.core import types
from numba.core.errors import TypingError
from numba.extending import intrinsic

from clothtool._jit import plain_integers

# slot -> (dispatcher, argument types) of each call compiled since the last clear: what
# clothtool.solver.framefn.compile_for puts in the table when it compiles a frame function
TYPED_SLOTS: dict[int, tuple] = {}


def callee_token(dispatcher, argument_types: tuple) -> int:
    """A number naming ``dispatcher``'s function compiled for ``argument_types``, the same in
    every process (63 bits of a hash of its module, name and types)."""
    function = dispatcher.py_func
    text = f"{function.__module__}.{function.__qualname__}{tuple(argument_types)!r}"
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little") >> 1


@intrinsic
def call_kernel(typingctx, callees, slot, kernel, args):
    """Call the numba dispatcher ``kernel`` (a global) with the tuple ``args`` at the address
    in row ``slot`` (an integer constant) of the uint64 (slots, 2) array ``callees``."""
    if not isinstance(slot, types.IntegerLiteral):
        raise TypingError("call_kernel: the slot must be an integer constant")
    # integer constants typed as plain integers (as clothtool._jit's device helpers are): a
    # literal would compile the kernel again for each constant (pose_spheres(..., 0, ...)),
    # where the stage-by-stage path and warm-up use the plain overload
    signature = kernel.get_call_type(typingctx, tuple(map(plain_integers, args.types)), {})
    dispatcher = kernel.dispatcher
    row = slot.literal_value
    token = callee_token(dispatcher, tuple(signature.args))
    message = f"frame function: callee table row {row} does not hold {dispatcher.py_func.__qualname__} for these types"

    def codegen(context, builder, sig, llargs):
        # recorded here, not in typing: typing can try a call with types the function ends up without
        TYPED_SLOTS[row] = (dispatcher, tuple(signature.args))
        table = context.make_array(sig.args[0])(context, builder, llargs[0])
        word = ir.IntType(64)
        address = builder.load(builder.gep(table.data, [ir.Constant(word, 2 * row)]))
        found = builder.load(builder.gep(table.data, [ir.Constant(word, 2 * row + 1)]))
        with builder.if_then(builder.icmp_unsigned("!=", found, ir.Constant(word, token)), likely=False):
            context.call_conv.return_user_exc(builder, RuntimeError, (message,))
        function_type = context.call_conv.get_function_type(signature.return_type, signature.args)
        function = builder.inttoptr(address, function_type.as_pointer())
        values = [builder.extract_value(llargs[3], i) for i in range(len(args.types))]
        status, result = context.call_conv.call_function(builder, function, signature.return_type, signature.args, values)
        with builder.if_then(status.is_error, likely=False):  # (a kernel returning None reports "none", not "ok")
            context.call_conv.return_status_propagate(builder, status)
        return result

    return signature.return_type(callees, slot, kernel, args), codegen
