"""Imports flow one way (DESIGN.md section 2): ``cli -> bake -> {solver, scene, io, ...} ->
{fabric, mesh}``; ``cook`` needs only ``mesh`` and ``fabric``; the solver never imports
``cook``, ``io`` or click; ``scene``, ``solver``/``integrators`` and ``io`` import the neutral
modules, never each other.

Every ``from clothtool... import`` in the package (lazy ones inside functions included; not
type-only ones under ``if TYPE_CHECKING:``) is checked against the layers below; none may
break them.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "clothtool"

# Neutral modules: anything may import them; they import only each other. ``collision`` holds
# the collider values (DESIGN.md's neutral collision layer), ``usd_env`` how pxr is run.
NEUTRAL = {"errors", "inputs", "resources", "presets", "settings", "_jit", "_kernel_cache", "_simd", "_simd_python", "_minmax", "fabric",
           "mesh", "collision", "usd_env", "__init__"}
# What each layer may import besides the neutral modules.
ALLOWED = {
    "cook": set(),
    "io": set(),
    "scene": set(),
    "solver": {"sim", "profile"},
    "integrators": {"solver", "sim", "profile"},
    "sim": {"solver"},
}
# Layers above these may import anything except the command line.
TOP = {"cli", "__main__"}


def _layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def _runtime_nodes(tree: ast.AST):
    """Every node of ``tree`` except those under ``if TYPE_CHECKING:`` (type-only imports)."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            continue
        yield node
        yield from _runtime_nodes(node)


def _imports():
    for path in sorted(PACKAGE.rglob("*.py")):
        module = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts).removesuffix(".__init__")
        for node in _runtime_nodes(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("clothtool."):
                yield module, node.module
            elif isinstance(node, ast.ImportFrom) and node.module == "clothtool":
                # ``from clothtool import io`` imports the subpackage; ``__version__`` the package
                for alias in node.names:
                    is_module = (PACKAGE / alias.name).is_dir() or (PACKAGE / f"{alias.name}.py").is_file()
                    yield module, f"clothtool.{alias.name}" if is_module else "clothtool"
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.startswith("clothtool."):
                        yield module, alias.name


def _breaks_rule(source: str, target: str) -> bool:
    src, dst = _layer(source), _layer(target)
    if src == dst or dst in NEUTRAL or src in TOP:
        return False
    if dst in TOP:
        return True
    if src in NEUTRAL:
        return True
    if src in ALLOWED:
        return dst not in ALLOWED[src]
    return False  # bake, report, study, batch, ...: may import every layer below the CLI


def test_imports_follow_the_arrows():
    broken = sorted({f"{source} -> {target}" for source, target in _imports() if _breaks_rule(source, target)})
    assert not broken, "imports against DESIGN.md's arrows:\n" + "\n".join(broken)


def test_the_rules_catch_the_imports_they_forbid():
    """The checker itself: imports the arrows forbid are caught, the ones they allow are not."""
    assert _breaks_rule("clothtool.scene.scene", "clothtool.io.meshin")
    assert _breaks_rule("clothtool.scene.colliders", "clothtool.solver.collide")
    assert _breaks_rule("clothtool.solver.wind", "clothtool.cook.cooker")
    assert _breaks_rule("clothtool.io.cache", "clothtool.scene.colliders")
    assert _breaks_rule("clothtool.collision.colliders", "clothtool.solver.collide")
    assert _breaks_rule("clothtool.mesh.coloring", "clothtool.cook.phases")
    assert not _breaks_rule("clothtool.solver.wind", "clothtool.mesh.coloring")
    assert not _breaks_rule("clothtool.scene.colliders", "clothtool.collision.colliders")
    assert not _breaks_rule("clothtool.loading", "clothtool.io.meshin")
    assert not _breaks_rule("clothtool.cli.bake", "clothtool.scene.usdstage")
    found = set(_imports())
    assert ("clothtool.solver.wind", "clothtool.mesh.coloring") in found  # the scan sees imports
    assert ("clothtool.cli.warmup", "clothtool._kernel_cache") in found  # ``from clothtool import x`` too


def test_solver_never_imports_click():
    for source, target in _imports():
        assert not (_layer(source) in ("solver", "integrators", "sim") and target.startswith("clothtool.cli")), source
    for path in (PACKAGE / "solver").rglob("*.py"):
        assert "import click" not in path.read_text(), path
