"""A frame's iterations in one compiled call: the frame function of a stage list.

Each stage that can run compiled gives a ``FusedCall``: the source lines of one iteration
(the same kernel calls, with the same arguments, as its ``run``) and the arrays and scalars
they read. Per-iteration values (frame terms, collider poses, alphas) are stacks over the
frame's iterations, indexed by ``it``; the stage computed them in ``begin_frame`` and its
``run`` indexes the same stacks, so both paths give the same bits. From the stage list this
module writes the source of one function,

    def frame(iterations, cur, prev, <each stage's arguments>, callees):
        for it in range(iterations):
            <each stage's lines>
        return iterations

which calls the stages' kernels through a table of their addresses (the last argument,
``callees``; clothtool.solver.framecall: nothing of theirs compiles again) and returns early
when the sleep stage puts the cloth to sleep. Only the stages the scene needs appear, so a
scene's frame function compiles only its own kernels.

Caching: the generated module is written to the kernel cache's key directory under a name
that is the hash of its source (clothtool._kernel_cache: the key already covers every
package source, so a changed kernel gives a new key; the file's own contents stamp its
compiled entry), and the frame function is cached there like any kernel: its code names no
other compiled function, so it loads in any process. Without a usable cache directory the
module is compiled in memory.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import operator
import os
import pickle
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np

from clothtool.solver.framecall import TYPED_SLOTS, callee_token

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


def _unlinked_calls(line: str, aliases: list[str], slots: list[str]) -> str:
    """``alias(a, b)`` -> ``call_kernel(callees, slot, alias, (a, b,))`` for each kernel alias
    in ``line``, each call with a slot of its own (appended to ``slots``: the alias it calls)."""
    for alias in aliases:
        start = line.find(alias + "(")
        while start >= 0:
            open_at = start + len(alias)
            depth, end = 0, open_at
            for end in range(open_at, len(line)):
                depth += {"(": 1, ")": -1}.get(line[end], 0)
                if depth == 0:
                    break
            line = f"{line[:start]}call_kernel(callees, {len(slots)}, {alias}, ({line[open_at + 1:end]},)){line[end + 1:]}"
            slots.append(alias)
            start = line.find(alias + "(", start + len("call_kernel("))
    return line


def frame_source(calls: list[FusedCall]) -> tuple[str, list]:
    """(module source, argument values in the order of the frame function's parameters, all
    but the last: the callee table, which compile_for makes). The module's ``CALLEES`` names
    the kernel each row of the table is for."""
    imports, made = ["from clothtool._jit import kernel", "from clothtool.solver.framecall import call_kernel"], []
    parameters, values, body = [], [], []
    slots: list[str] = []
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
        body += [f"        {_unlinked_calls(line.format(**names), aliases, slots)}" for line in call.lines]
    signature = ", ".join(["iterations", "cur", "prev"] + parameters + ["callees"])
    # Without numba's reference counting (_nrt=False): the function only reads and indexes its
    # arguments, which Python owns for the call, and allocates nothing; counting references
    # to ~100 arrays and their views was a quarter of its compile time (~0.2 s for the walk).
    source = "\n".join(
        ['"""A frame function written by clothtool.solver.framefn."""', *sorted(set(imports)), *made,
         f"CALLEES = {tuple(slots)!r}", "", "",
         "@kernel(_nrt=False)", f"def frame({signature}):", "    for it in range(iterations):", *body, "    return iterations", ""]
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


# the calls' lines, argument names and kernels -> (source, function), for this process: a new
# solver (the next bake) with the same stages finds its frame function without writing it
_SHAPES: dict[tuple, tuple[str, object]] = {}


class FusedFrame:
    """One cloth's frame function: rebuilt when its stages' source changes (a stage that
    picks another kernel, colliders that appear), argument values gathered each frame."""

    def __init__(self) -> None:
        self.source = ""
        self.function: object = None
        # the last frame's calls, their shapes (_call_shape) and the shape of them all: a
        # stage that gives the very FusedCall of the last frame (its values stand) is not
        # looked at again, and calls of the last frame's shapes need no _SHAPES look-up
        self._calls: list[FusedCall] = []
        self._call_shapes: list[tuple] = []
        self._shape: tuple | None = None
        self._values: list = []  # the last frame's argument values, in the calls' order

    def prepare(self, stages) -> tuple[object, list, bool]:
        """(function, argument values, True when the function is new in this solver)."""
        calls = [stage.fused_call() for stage in stages]
        last_calls, last_shapes = self._calls, self._call_shapes
        if self._shape is not None and len(calls) == len(last_calls) and all(map(operator.is_, calls, last_calls)):
            return self.function, self._values, False  # every call stands (a usual frame): so do the values
        if len(calls) == len(last_calls):
            shapes = [last if call is old else _call_shape(call) for call, old, last in zip(calls, last_calls, last_shapes)]
        else:
            shapes = [_call_shape(call) for call in calls]
        if shapes != last_shapes or self._shape is None:  # equal shapes: the same function
            # the kernels themselves, not their ids: the key keeps them alive, so no id is reused
            shape = tuple(shapes)
            known = _SHAPES.get(shape)
            if known is None:
                source, _ = frame_source(calls)
                known = _SHAPES[shape] = (source, compile_frame(source))
            self._shape = shape
            new = known[0] is not self.source
            self.source, self.function = known
        else:
            new = False
        self._calls, self._call_shapes = calls, shapes
        self._values = [value for call in calls for value in call.args.values()]
        return self.function, self._values, new


def _call_shape(call: FusedCall) -> tuple:
    """What of ``call`` its part of the frame function's source depends on: its lines, the
    names of its values and its kernels."""
    return call.lines, tuple(call.args), tuple(call.kernels.values())


# (frame function, argument types) -> its callee table, in this process
_TABLES: dict[tuple, np.ndarray] = {}
# compile_for reads what typing left in TYPED_SLOTS: one compile at a time (bakes on threads)
_COMPILING = threading.Lock()


def compile_for(function, arguments: tuple) -> np.ndarray:
    """Compile ``function`` for the types of ``arguments`` (all but the callee table), or load
    it from the disk cache, without running it; returns the callee table to call it with.

    The table holds the address of each kernel the frame function calls
    (clothtool.solver.framecall) for the argument types it calls it with. Those types are
    learnt when the frame function is typed; a function loaded from the cache is not typed,
    so the first process to compile it records them beside the module (``_record_path``:
    the same for every process, as typing is), and a later process compiles or loads each
    callee for its recorded types and takes its address. The frame function compiles only
    inside this call: called with other types, it raises rather than compiling for a table
    made for these."""
    import numba

    types = tuple(numba.typeof(value) for value in arguments) + (numba.typeof(np.empty((0, 2), np.uint64)),)
    with _COMPILING:
        table = _TABLES.get((function, types))
        if table is None:
            table = _TABLES[(function, types)] = _compile_table(function, types)
    return table


def _compile_table(function, types: tuple) -> np.ndarray:
    """compile_for's work: compile or load ``function`` for ``types``, then its callee table."""
    import numba

    namespace = function.py_func.__globals__
    aliases = namespace["CALLEES"]
    record_path = _record_path(function)
    record = _read_record(record_path)
    known = record.get(repr(types))
    if not isinstance(known, list) or len(known) != len(aliases):
        known = None  # not recorded yet (or a damaged record: typed again and rewritten)
    TYPED_SLOTS.clear()
    function.disable_compile(False)
    try:
        if known is None:
            # typed here even when the disk cache holds the function: the types are not recorded
            cache, function._cache = function._cache, _SaveOnly(function._cache)
            try:
                function.compile(types)
            finally:
                function._cache = cache
        else:
            function.compile(types)
    finally:
        function.disable_compile(True)
    if known is None or TYPED_SLOTS:  # typed in this process
        callees = [TYPED_SLOTS.get(slot) for slot in range(len(aliases))]
        typed = [None if callee is None else callee[1] for callee in callees]
        if typed != known:
            record[repr(types)] = typed
            _write_record(record_path, record)
    else:  # loaded from the disk cache
        callees = [
            None if argument_types is None else (numba.typeof(namespace[alias]).dispatcher, argument_types)
            for alias, argument_types in zip(aliases, known)
        ]
    return _callee_table(callees)


def _callee_table(callees: list) -> np.ndarray:
    """uint64 (slots, 2): each callee's address and token (zeros for a call never typed: a
    branch numba removed)."""
    table = np.zeros((len(callees), 2), np.uint64)
    for row, callee in enumerate(callees):
        if callee is None:
            continue
        dispatcher, argument_types = callee
        dispatcher.compile(argument_types)
        compiled = dispatcher.overloads[argument_types]
        table[row] = compiled.library.get_pointer_to_function(compiled.fndesc.llvm_func_name), callee_token(
            dispatcher, argument_types
        )
    return table


class _SaveOnly:
    """A dispatcher's disk cache that saves what compiles but never loads."""

    def __init__(self, cache) -> None:
        self._cache = cache

    def load_overload(self, *args):
        return None

    def __getattr__(self, name: str):
        return getattr(self._cache, name)


def _record_path(function) -> Path | None:
    """Where the argument types of ``function``'s callees are recorded: beside its module in
    the cache (None for a module compiled in memory)."""
    module = sys.modules.get(function.py_func.__module__)
    path = getattr(module, "__file__", None)
    return None if path is None else Path(path).with_suffix(".callees")


def _read_record(path: Path | None) -> dict:
    """frame argument types (repr) -> each slot's callee argument types (None: never typed)."""
    if path is None:
        return {}
    try:
        with open(path, "rb") as stream:
            record = pickle.load(stream)
    except (OSError, EOFError, pickle.UnpicklingError, AttributeError, ImportError, TypeError):
        return {}  # none yet, or unreadable: typed again and rewritten
    return record if isinstance(record, dict) else {}


def _write_record(path: Path | None, record: dict) -> None:
    """Replace the record atomically (two processes write the same types for the same key)."""
    if path is None:
        return
    try:
        handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
    except OSError:
        return  # a read-only cache: the next process types the function again
    try:
        with os.fdopen(handle, "wb") as stream:
            pickle.dump(record, stream)
        os.replace(temporary, path)
    except OSError:
        Path(temporary).unlink(missing_ok=True)


def stacked(values, dtype) -> np.ndarray:
    """A contiguous array of per-iteration values (a stack the frame function indexes)."""
    return np.ascontiguousarray(np.asarray(values, dtype))


def held(array: np.ndarray | None, values, dtype) -> np.ndarray:
    """``stacked(values, dtype)`` written into ``array`` when it has their shape and ``dtype``
    (the same object as last frame, so that a stage's fused call stands: ``standing``)."""
    values = np.asarray(values)
    if array is None or array.shape != values.shape or array.dtype != np.dtype(dtype):
        return stacked(values, dtype)
    np.copyto(array, values, casting="same_kind")  # the conversion np.asarray(values, dtype) makes
    return array


def standing(call: FusedCall | None, lines: tuple[str, ...], names: tuple[str, ...], values: tuple,
             kernels: dict) -> FusedCall:
    """``call`` when it is made of these very lines, kernels and argument objects (``values``,
    by ``names``: the last frame's call, so FusedFrame.prepare has nothing to look at again),
    else a new call."""
    if (
        call is not None
        and call.lines is lines
        and call.kernels is kernels
        and len(call.args) == len(values)
        and all(map(operator.is_, values, call.args.values()))
    ):
        return call
    return FusedCall(lines, dict(zip(names, values)), kernels)
