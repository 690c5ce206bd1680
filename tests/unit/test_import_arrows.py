"""Imports flow one way (DESIGN.md section 2): ``cli -> bake -> {solver, scene, io, ...} ->
{fabric, mesh}``; ``cook`` needs only ``mesh`` and ``fabric``; the solver never imports
``cook``, ``io`` or click; ``scene``, ``solver``/``integrators`` and ``io`` import the neutral
modules, never each other.

Every ``from clothtool... import`` in the package (lazy ones inside functions included; not
type-only ones under ``if TYPE_CHECKING:``) is checked against the layers below. The imports that still break the rules are listed in
KNOWN, one line each: the test fails when a new one appears, and when one on the list is
gone (so that the list only shrinks).
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "clothtool"

# Neutral modules: anything may import them; they import only each other. ``collision`` holds
# the collider values (DESIGN.md's neutral collision layer), ``usd_env`` how pxr is run.
NEUTRAL = {"errors", "inputs", "resources", "presets", "settings", "_jit", "_kernel_cache", "_simd", "_simd_python", "fabric",
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

KNOWN = {
    "clothtool.scene.colliders -> clothtool.io.meshin",
    "clothtool.scene.scene -> clothtool.cook.cooker",
    "clothtool.scene.scene -> clothtool.io.fabric_file",
    "clothtool.scene.scene -> clothtool.io.meshin",
    "clothtool.scene.usdstage -> clothtool.cook.cooker",
    "clothtool.scene.usdstage -> clothtool.io.meshin",
}


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
    broken = {f"{source} -> {target}" for source, target in _imports() if _breaks_rule(source, target)}
    new = sorted(broken - KNOWN)
    assert not new, "imports against DESIGN.md's arrows:\n" + "\n".join(new)
    gone = sorted(KNOWN - broken)
    assert not gone, "no longer imported, remove from KNOWN:\n" + "\n".join(gone)


def test_solver_never_imports_click():
    for source, target in _imports():
        assert not (_layer(source) in ("solver", "integrators", "sim") and target.startswith("clothtool.cli")), source
    for path in (PACKAGE / "solver").rglob("*.py"):
        assert "import click" not in path.read_text(), path
