"""``call_kernel(kernel, (args...))``: call a compiled kernel from compiled code without
linking it in.

A numba function that calls another one links the callee's code into its own and compiles
it again to machine code: a frame function calling every stage kernel would pay the
kernels' code generation a second time (seconds for the collision kernels). Here the call
goes to the callee's already compiled symbol (the same machine code the stage-by-stage path
runs): the caller only declares it. The callee must therefore be compiled or loaded in this
process before the caller is, for the same argument types: the frame function is compiled
in-process (never loaded from disk), and typing it compiles or loads every callee
(clothtool.solver.framefn.compile_for).
"""

from __future__ import annotations

from numba.core import cgutils
from numba.extending import intrinsic


@intrinsic
def call_kernel(typingctx, kernel, args):
    """Call the numba dispatcher ``kernel`` (a global) with the tuple ``args``."""
    signature = kernel.get_call_type(typingctx, tuple(args.types), {})
    dispatcher = kernel.dispatcher

    def codegen(context, builder, sig, llargs):
        compiled = dispatcher.get_compile_result(signature)
        function_type = context.call_conv.get_function_type(signature.return_type, signature.args)
        function = cgutils.get_or_insert_function(builder.module, function_type, compiled.fndesc.llvm_func_name)
        values = [builder.extract_value(llargs[1], i) for i in range(len(args.types))]
        status, result = context.call_conv.call_function(builder, function, signature.return_type, signature.args, values)
        with builder.if_then(status.is_error, likely=False):  # (a kernel returning None reports "none", not "ok")
            context.call_conv.return_status_propagate(builder, status)
        return result

    return signature.return_type(kernel, args), codegen
