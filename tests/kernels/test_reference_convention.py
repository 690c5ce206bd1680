"""Convention: every numba kernel has a plain-numpy reference and a comparison test.

A kernel is a numba dispatcher defined in a clothtool module; its module is every module of
clothtool.solver.kernels and any other module that imports clothtool._jit and defines one
(today the mesh colouring and the cook's phases, among others). For a kernel module ``x`` there must be

* ``tests/reference/x.py`` with a plain function of the same name for each kernel (no numba),
  private helpers included;
* a test module (``tests/kernels/test_x.py``, or any ``tests/**/test_*.py``, e.g. next to
  an integrator's other tests) importing each public kernel from its module and the reference
  module, to compare the two. Private helpers (``inline="always"`` pieces of public kernels)
  are compared through the kernels that use them, unless a module has no public kernel.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
from pathlib import Path

import pytest
from numba.core.registry import CPUDispatcher

import clothtool.solver.kernels as kernel_package
from tests.conftest import REPO

PACKAGE = REPO / "clothtool"
REFERENCE = REPO / "tests" / "reference"
TESTS = REPO / "tests" / "kernels"


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(REPO).with_suffix("").parts)


def _imports(path: Path) -> set[str]:
    """Modules imported by the source at ``path`` (absolute names only)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
    return names


def kernel_modules() -> list[str]:
    """Every module of the kernels package, and every other module that imports
    clothtool._jit and defines a kernel (one may import it for a typing helper only)."""
    modules = {f"{kernel_package.__name__}.{info.name}" for info in pkgutil.iter_modules(kernel_package.__path__)}
    for path in PACKAGE.rglob("*.py"):
        if path.name != "_jit.py" and "clothtool._jit" in _imports(path) and kernels_of(_module_name(path)):
            modules.add(_module_name(path))
    return sorted(modules)


def kernels_of(module_name: str) -> dict[str, CPUDispatcher]:
    module = importlib.import_module(module_name)
    return {
        name: obj
        for name, obj in vars(module).items()
        if isinstance(obj, CPUDispatcher) and obj.py_func.__module__ == module_name
    }


MODULES = kernel_modules()


def test_the_scan_finds_the_known_kernel_modules():
    expected = {"integrate", "wind", "constraints", "fabric", "stats"}
    assert {m.rsplit(".", 1)[1] for m in MODULES if m.startswith(kernel_package.__name__)} >= expected
    assert {"clothtool.mesh.coloring", "clothtool.cook.phases"} <= set(MODULES)


def test_kernel_module_names_are_unique():
    """References are named after the kernel module's last name part, so two kernel modules
    may not share one (rename one, or give the reference directory a sub-package)."""
    stems = [m.rsplit(".", 1)[1] for m in MODULES]
    assert len(stems) == len(set(stems)), stems


@pytest.mark.parametrize("module_name", MODULES)
def test_every_kernel_has_a_reference_and_a_test(module_name):
    stem = module_name.rsplit(".", 1)[1]
    kernels = kernels_of(module_name)
    if module_name.startswith(kernel_package.__name__):
        assert kernels, f"{module_name} is in the kernels package but defines no numba kernel"
    reference_path = REFERENCE / f"{stem}.py"
    assert reference_path.exists(), f"{module_name} has kernels {sorted(kernels)}: write {reference_path.relative_to(REPO)}"
    imported = _imports(reference_path)
    assert not any(name.split(".")[0] == "numba" for name in imported), (
        f"{reference_path.relative_to(REPO)} must be plain numpy: it imports numba"
    )
    assert not any(name.startswith(module_name) for name in imported), (
        f"{reference_path.relative_to(REPO)} imports the kernel module it should check"
    )
    reference = importlib.import_module(f"tests.reference.{stem}")
    for name in kernels:
        function = getattr(reference, name, None)
        assert callable(function), f"{reference_path.relative_to(REPO)} has no reference function {name}()"
        assert function.__module__ == reference.__name__ and not isinstance(function, CPUDispatcher)

    public = [name for name in kernels if not name.startswith("_")] or list(kernels)
    wanted = {f"{module_name}.{name}" for name in public} | {f"tests.reference.{stem}"}
    comparing = [path for path in REPO.joinpath("tests").rglob("test_*.py") if wanted <= _imports(path)]
    assert comparing, (
        f"{module_name}: no test imports all of {sorted(wanted)}; write {(TESTS / f'test_{stem}.py').relative_to(REPO)} "
        "comparing each kernel with its reference"
    )


def test_every_reference_module_belongs_to_a_kernel_module():
    stems = {m.rsplit(".", 1)[1] for m in MODULES}
    orphans = [p.name for p in REFERENCE.glob("*.py") if not p.name.startswith("_") and p.stem not in stems]
    assert not orphans, f"tests/reference modules without a kernel module: {orphans}"
