"""A frame's iterations in one compiled call: the frame function of a stage list.

Each stage that can run compiled gives a ``FusedCall``: the source lines of one iteration
(the same kernel calls, with the same arguments, as its ``run``) and the arrays and scalars
they read. Per-iteration values (frame terms, collider poses, alphas) are stacks over the
frame's iterations, indexed by ``it``; the stage computed them in ``begin_frame`` and its
``run`` indexes the same stacks, so both paths give the same bits. From the stage list this
module writes the source of one function,

    def frame(iterations, cur, prev, <each stage's arguments>):
        for it in range(iterations):
            <each stage's lines>
        return iterations

which calls the stages' kernels (numba links the compiled kernels in; nothing else compiles)
and returns early when the sleep stage puts the cloth to sleep. Only the stages the scene
needs appear, so a scene's frame function compiles only its own kernels.

Caching: the generated module is written to the kernel cache's key directory under a name
that is the hash of its source (clothtool._kernel_cache: the key already covers every
package source, so a changed kernel gives a new key; the file's own contents stamp its
compiled entry). The frame function itself is compiled in each process, never loaded from
the disk cache (``compile_for`` says why). Without a usable cache directory the module is
compiled in memory.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

GENERATED_DIR = "generated"
_COMPILED: dict[str, object] = {}  # source -> dispatcher, for this process


@dataclasses.dataclass(frozen=True)
class FusedCall:
    """One stage's part of an iteration in the frame function.

    lines: source lines (no indentation) in which ``{name}`` stands for ``args[name]`` or
    ``kernels[name]``; ``it``, ``cur`` and ``prev`` are the iteration index and the state.
    args: arrays and scalars (passed as the frame function's arguments, in this order).
    kernels: compiled functions the lines call (imported by the generated module)."""

    lines: tuple[str, ...]
    args: dict
    kernels: dict


def _import_lines(alias: str, dispatcher) -> list[str]:
    """How the generated module gets a kernel as ``alias``: the module attribute it is, or
    the expression it names in ``frame_import`` (a kernel made by a factory)."""
    module_name = dispatcher.py_func.__module__
    made = getattr(dispatcher, "frame_import", None)
    if made is not None:
        factory = made.split("(", 1)[0]
        return [f"from {module_name} import {factory}", f"{alias} = {made}"]
    for name, value in vars(sys.modules[module_name]).items():
        if value is dispatcher:
            return [f"from {module_name} import {name} as {alias}"]
    raise LookupError(f"kernel {dispatcher.py_func.__qualname__} is not an attribute of {module_name}")


def copy_lines(source: str, target: str, columns: str = "{target}.shape[1]") -> tuple[str, ...]:
    """Lines copying 2-d ``source`` into ``target`` row by row (``columns`` of each): loops,
    not a slice assignment, which would compile numba's shape-mismatch message (seconds)."""
    columns = columns.format(target=target)
    return (
        f"for row in range({target}.shape[0]):",
        f"    for column in range({columns}):",
        f"        {target}[row, column] = {source}[row, column]",
    )


def _unlinked_calls(line: str, aliases: list[str]) -> str:
    """``alias(a, b)`` -> ``call_kernel(alias, (a, b,))`` for each kernel alias in ``line``."""
    for alias in aliases:
        start = line.find(alias + "(")
        while start >= 0:
            open_at = start + len(alias)
            depth, end = 0, open_at
            for end in range(open_at, len(line)):
                depth += {"(": 1, ")": -1}.get(line[end], 0)
                if depth == 0:
                    break
            line = f"{line[:start]}call_kernel({alias}, ({line[open_at + 1:end]},)){line[end + 1:]}"
            start = line.find(alias + "(", start + len("call_kernel("))
    return line


def frame_source(calls: list[FusedCall]) -> tuple[str, list]:
    """(module source, argument values in the order of the frame function's parameters)."""
    imports, made = ["from clothtool._jit import kernel", "from clothtool.solver.framecall import call_kernel"], []
    parameters, values, body = [], [], []
    for index, call in enumerate(calls):
        names = {}
        for name, value in call.args.items():
            names[name] = f"s{index}_{name}"
            parameters.append(names[name])
            values.append(value)
        for name, dispatcher in call.kernels.items():
            alias = f"k{index}_{name}"
            names[name] = alias
            lines = _import_lines(alias, dispatcher)
            imports.append(lines[0])
            made += lines[1:]
        body.append(f"        # stage {index}")
        aliases = [names[name] for name in call.kernels]
        body += [f"        {_unlinked_calls(line.format(**names), aliases)}" for line in call.lines]
    signature = ", ".join(["iterations", "cur", "prev"] + parameters)
    source = "\n".join(
        ['"""A frame function written by clothtool.solver.framefn."""', *sorted(set(imports)), *made, "", "",
         "@kernel", f"def frame({signature}):", "    for it in range(iterations):", *body, "    return iterations", ""]
    )
    return source, values


def _write_module(source: str) -> Path | None:
    """The generated module's file in the cache's key directory (written once, atomically),
    or None when there is no usable cache directory."""
    from clothtool._kernel_cache import usable_key_directory

    directory = usable_key_directory()
    if directory is None:
        return None
    folder = directory / GENERATED_DIR
    path = folder / f"frame_{hashlib.sha256(source.encode()).hexdigest()[:24]}.py"
    try:
        if path.exists() and path.read_text() == source:
            return path
        folder.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(handle, "w") as stream:
            stream.write(source)
        os.replace(temporary, path)
    except OSError:
        return None
    return path


def compile_frame(source: str):
    """The dispatcher of the frame function ``source`` defines (cached per process, and on
    disk through the kernel cache)."""
    dispatcher = _COMPILED.get(source)
    if dispatcher is not None:
        return dispatcher
    path = _write_module(source)
    digest = hashlib.sha256(source.encode()).hexdigest()[:24]
    if path is not None:
        spec = importlib.util.spec_from_file_location(f"clothtool_generated_frame_{digest}", path)
        assert spec is not None and spec.loader is not None  # a .py file path always has both
        module = importlib.util.module_from_spec(spec)
        # numba's cached entries re-import the function's module by name when they load
        sys.modules[spec.name] = module
        spec.loader.exec_module(module)
        namespace: dict = vars(module)
    else:
        namespace = {}
        exec(compile(source, f"<clothtool frame {digest}>", "exec"), namespace)
    dispatcher = _COMPILED[source] = namespace["frame"]
    return dispatcher


class FusedFrame:
    """One cloth's frame function: rebuilt when its stages' source changes (a stage that
    picks another kernel, colliders that appear), argument values gathered each frame."""

    def __init__(self) -> None:
        self.source = ""
        self.function: object = None
        self._shapes: dict[tuple, tuple[str, object]] = {}  # the calls' lines and kernels -> (source, function)

    def prepare(self, stages) -> tuple[object, list, bool]:
        """(function, argument values, True when the function is new in this solver)."""
        calls = [stage.fused_call() for stage in stages]
        shape = tuple((call.lines, tuple(call.args), tuple(map(id, call.kernels.values()))) for call in calls)
        known = self._shapes.get(shape)
        if known is None:
            source, _ = frame_source(calls)
            known = self._shapes[shape] = (source, compile_frame(source))
        values = [value for call in calls for value in call.args.values()]
        new = known[0] != self.source
        self.source, self.function = known
        return self.function, values, new


def compile_for(function, arguments: tuple) -> None:
    """Compile ``function`` for the types of ``arguments`` without running it, in this
    process, never from the disk cache. Its kernels are called unlinked
    (clothtool.solver.framecall): a cached frame function calls its callees' symbols as they
    were when it was saved, and a cache filled by two processes at once (parallel bakes,
    pytest -n 2) could hold callees saved by the other process under other symbols: loading
    it then segfaulted. Compiled here, it calls the symbols this process has (about 0.7 s for
    the walk, once per process; the kernels themselves still come from the cache)."""
    import numba
    from numba.core.caching import NullCache

    types = tuple(numba.typeof(value) for value in arguments)
    if types in function.overloads:
        return
    function._cache = NullCache()
    function.compile(types)


def stacked(values, dtype) -> np.ndarray:
    """A contiguous array of per-iteration values (a stack the frame function indexes)."""
    return np.ascontiguousarray(np.asarray(values, dtype))
