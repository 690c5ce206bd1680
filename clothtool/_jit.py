"""The one place that configures numba.

Compiled kernels are cached on disk by clothtool._kernel_cache (a user cache directory, keyed
by the contents of the sources rather than their path), so a second run pays no compile time. Of fastmath's flags only ``contract`` is on: it fuses
multiply-adds (about 20% off the fabric kernel, whose cost is its dependency chain) and, unlike
the others, keeps NaN/inf semantics (the instability checks rely on them) and the bit-identity
of a kernel's serial and parallel versions (tested). numba is imported lazily by the
modules that hold kernels, never by ``import clothtool``.
"""

from __future__ import annotations

import os
import types
from typing import cast

# Idle OpenMP threads spin by default. On a machine shared with other jobs (a render node,
# --jobs N bakes, CI) the spinning threads of one process starve the others and a parallel
# kernel call can stall for milliseconds; passive waiting costs ~10% on an idle machine.
# Must be set before numba first starts its thread pool; a user's own setting wins.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")

import numba  # noqa: E402  (after the environment above)
from numba.core import types as numba_types  # noqa: E402
from numba.core.datamodel import models, register_default  # noqa: E402
from numba.core.dispatcher import Dispatcher  # noqa: E402
from numba.core.registry import CPUDispatcher  # noqa: E402

from clothtool._kernel_cache import attach_cache  # noqa: E402

# No ``cache=True``: numba's own cache is path-keyed and fails on read-only installs;
# ``_compile`` attaches clothtool's cache instead.
# ``no_cfunc_wrapper``: nothing takes a kernel's C function pointer (numba.cfunc, first-class
# function values); kernels call each other natively, Python calls them through their CPython
# wrapper. Without it every kernel compiled a C wrapper too (unboxing each argument again).
# ``_nrt=True`` (numba's reference counting, its default) is said explicitly: a kernel that
# compiles while another function is being compiled (a frame function types the kernels it
# calls) otherwise inherits that function's setting, and frame functions compile without.
KERNEL_OPTIONS = dict(
    nogil=True, fastmath={"contract"}, error_model="numpy", boundscheck=False, no_cfunc_wrapper=True, _nrt=True
)


def kernel(func=None, **overrides):
    """``numba.njit`` with the project's options; usable as ``@kernel`` or ``@kernel(parallel=True)``.

    ``inline="always"`` (a helper to inline into every kernel that calls it) is done by LLVM,
    not by numba: the helper is compiled once, marked ``alwaysinline`` (numba's
    ``forceinline``), and LLVM's always-inliner puts it into each caller. numba's own
    inlining copies and types the helper's IR again at every call site, which was a third
    of the fabric and face-point kernels' compile time (the walk's cold start as a whole
    gains little: the helpers now compile on their own). Bakes stay bit-identical and the
    walk bake's simulation takes ~6% less CPU.

    ``device=True`` (implied by ``inline="always"``): a helper that only other kernels call
    (see ``DeviceKernel``)."""
    options = {**KERNEL_OPTIONS, **overrides}
    device = options.pop("device", False)
    if options.get("inline") == "always":
        del options["inline"]
        options["forceinline"] = True
        device = True
    make = _compile_device if device else _compile
    if func is None:
        return lambda f: make(f, options)
    return make(func, options)


def _compile(func, options: dict):
    dispatcher = numba.njit(**options)(func)
    if isinstance(dispatcher, Dispatcher):  # not under NUMBA_DISABLE_JIT=1, where njit returns func
        attach_cache(dispatcher)
    return dispatcher


class DeviceKernel(CPUDispatcher):
    """A helper of other kernels. Kernels that call it see (compile, and link in) its twin,
    compiled without the CPython and C wrappers: only a call from Python needs those, and
    they were about a third of a helper's compile time (their code went through LLVM too,
    to be thrown away). The dispatcher itself, wrappers included, compiles only when Python
    calls it (the kernel tests). Same code either way: the wrappers only call the function."""

    twin: Dispatcher

    @property
    def _numba_type_(self):
        return _DeviceType(self.twin)


class _DeviceType(numba_types.Dispatcher):
    """The numba type of a device kernel's twin: calls are typed with integer literals made
    plain integers. Typed as they are, a constant argument (``_row(m, 0, ...)``) or a variable
    whose type inference has seen only its first, constant value (``start = 0`` before a loop)
    compiled the helper once per literal; the machine code is the same (LLVM propagates the
    constant after inlining). Boolean literals stay: they let numba prune a helper's branches."""

    def get_call_type(self, context, args, kws):
        return super().get_call_type(context, tuple(map(plain_integers, args)), {k: plain_integers(v) for k, v in kws.items()})


register_default(_DeviceType)(models.OpaqueModel)  # as numba's own Dispatcher type


def plain_integers(ty):
    """``ty`` with integer literals (also inside tuples) made their plain integer type."""
    if isinstance(ty, numba_types.IntegerLiteral):
        return ty.literal_type
    if isinstance(ty, numba_types.BaseTuple) and not isinstance(ty, numba_types.BaseNamedTuple):
        return numba_types.BaseTuple.from_types([plain_integers(t) for t in ty.types])
    return ty


def _compile_device(func, options: dict):
    dispatcher = _compile(func, options)
    if not isinstance(dispatcher, Dispatcher):
        return dispatcher
    dispatcher.__class__ = DeviceKernel  # made by njit as usual, then given the twin
    device = cast(DeviceKernel, dispatcher)
    device.twin = _compile(_renamed(func, "_device"), {**options, "no_cpython_wrapper": True, "no_cfunc_wrapper": True})
    return device


def _renamed(func, suffix: str):
    """A copy of ``func`` named with ``suffix``: its own numba cache entries."""
    copy = types.FunctionType(func.__code__, func.__globals__, func.__name__ + suffix, func.__defaults__, func.__closure__)
    copy.__qualname__ = func.__qualname__ + suffix
    return copy


def serial_and_parallel(func):
    """Two compilations of one kernel source: serial, and parallel (``numba.prange`` loops run
    on all cores). Each gets its own function name, so their numba cache entries stay apart;
    kernels written for this only prange over conflict-free work, so both give the same bits."""

    return kernel(_renamed(func, "_serial")), kernel(parallel=True)(_renamed(func, "_parallel"))
