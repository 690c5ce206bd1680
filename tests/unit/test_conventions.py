"""Project conventions, checked by tests rather than by review."""

from __future__ import annotations

import ast
import re
import subprocess
import sys

import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.fabric import ARRAY_FIELDS, ATTR_FIELDS, FORMAT_VERSION

from tests.conftest import REPO

README = (REPO / "README.md").read_text()


def test_import_is_light():
    code = "import sys, clothtool, clothtool.cli; print(sorted(m for m in ('numba', 'h5py', 'pxr', 'trimesh', 'meshio', 'scipy', 'matplotlib') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.parametrize("command", sorted(main.commands))
def test_every_command_has_help_and_a_readme_section(command):
    result = CliRunner().invoke(main, [command, "--help"])
    assert result.exit_code == 0 and "Usage:" in result.output
    assert f"### `clothtool {command}" in README, f"README has no section for 'clothtool {command}'"


def test_every_fabric_field_is_specified():
    spec = (REPO / "formats" / "fabric" / f"v{FORMAT_VERSION}.md").read_text()
    for name, _, _ in ARRAY_FIELDS:
        assert f"| `{name}` |" in spec, name
    for name in ATTR_FIELDS:
        assert f"`{name}`" in spec, name


def test_every_preset_is_documented_in_the_readme():
    for kind in ("material", "solver", "cook"):
        for path in (REPO / "presets" / kind).glob("*.toml"):
            assert f"`{path.stem}`" in README, f"{kind} preset {path.stem} is not in the README"


def test_no_print_or_exit_below_the_cli():
    offenders = []
    for path in (REPO / "clothtool").rglob("*.py"):
        if "cli" in path.relative_to(REPO / "clothtool").parts:
            continue
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                name = node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", "")
                owner = getattr(node.func, "value", None)
                if name == "print" or (name == "exit" and isinstance(owner, ast.Name) and owner.id == "sys"):
                    offenders.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert offenders == []


def test_readme_setup_block_is_what_ci_runs():
    block = re.search(r"<!-- setup:begin -->\n```\n(.*?)```\n<!-- setup:end -->", README, re.S)
    assert block, "README lost its setup block"
    commands = [line for line in block.group(1).splitlines() if line.strip()]
    assert len(commands) == 2, "the README's set-up is two commands"
    assert "pip install" in commands[0] and "pytest" in commands[1]
    assert "README.md" in (REPO / ".ci" / "run").read_text()
