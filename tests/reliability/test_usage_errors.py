"""Outputs onto inputs, outputs a command cannot write, settings that cannot be meant, and the
messages of bad input: each is one line with the right exit code, and nothing is destroyed."""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid

REPO = Path(__file__).resolve().parents[2]
CAPE = REPO / "examples" / "cape" / "cape.obj"
SKIRT = REPO / "examples" / "skirt" / "skirt.usda"

SCENE = """version = 1
[scene]
fps = 24.0
frames = [1, 3]
[solver]
preset = "preview"
[cloth.sheet]
{source}
material = "cotton"
"""


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def one_error_line(result) -> str:
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.stderr
    return lines[0]


@pytest.fixture
def folder(tmp_path) -> Path:
    path = tmp_path / "sub"
    path.mkdir()
    write_fabric(cook_fabric(grid(5, 5, 0.1, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 1))).fabric,
                 path / "sheet.fabric.h5")
    (path / "scene.toml").write_text(SCENE.format(source='fabric = "sheet.fabric.h5"'))
    return path


# --------------------------------------------------------------------------- outputs onto inputs
def test_cook_refuses_to_write_over_its_mesh(tmp_path):
    mesh = tmp_path / "cape.obj"
    mesh.write_bytes(CAPE.read_bytes())
    result = run("cook", mesh, "-o", mesh)
    assert result.exit_code == 2
    assert "a fabric is an HDF5 file" in one_error_line(result)
    assert mesh.read_bytes() == CAPE.read_bytes()


def test_cook_refuses_a_hard_link_to_its_mesh(tmp_path):
    mesh = tmp_path / "cape.obj"
    mesh.write_bytes(CAPE.read_bytes())
    os.link(mesh, tmp_path / "cape.fabric.h5")
    result = run("cook", mesh, "-o", tmp_path / "cape.fabric.h5")
    assert result.exit_code == 2
    assert "is the input file" in one_error_line(result)
    assert mesh.read_bytes() == CAPE.read_bytes()


def test_bake_refuses_to_write_over_the_fabric_its_scene_reads(folder):
    fabric = folder / "sheet.fabric.h5"
    before = fabric.read_bytes()
    result = run("bake", folder / "scene.toml", "-o", fabric)
    assert result.exit_code == 2
    assert "the cache is the input file" in one_error_line(result)
    assert fabric.read_bytes() == before


def test_bake_refuses_to_write_over_the_mesh_its_scene_cooks(tmp_path):
    mesh = tmp_path / "skirt.usda"
    mesh.write_bytes(SKIRT.read_bytes())
    (tmp_path / "scene.toml").write_text(SCENE.format(source='mesh = "skirt.usda"\ncook = "garment"'))
    result = run("bake", tmp_path / "scene.toml", "-o", mesh)
    assert result.exit_code == 2
    assert "is the input file" in one_error_line(result)
    assert mesh.read_bytes() == SKIRT.read_bytes()


def test_bake_refuses_a_partial_or_report_onto_an_input(folder):
    fabric = folder / "sheet.fabric.h5"
    before = fabric.read_bytes()
    partial = folder / "sheet.fabric.partial.h5"
    partial.write_bytes(before)
    (folder / "scene.toml").write_text(SCENE.format(source='fabric = "sheet.fabric.partial.h5"'))
    result = run("bake", folder / "scene.toml", "-o", fabric)  # its partial name is the input
    assert result.exit_code == 2 and "partial cache" in one_error_line(result)
    (folder / "report.json").write_text("{}")
    scene = folder / "scene.toml"
    text = scene.read_text()
    result = run("bake", scene, "-o", folder / "x.h5", "--report", folder / "scene.json")
    assert result.exit_code == 0  # a report name that is not an input is fine
    os.link(scene, folder / "scene_link.json")
    result = run("bake", scene, "-o", folder / "y.h5", "--report", folder / "scene_link.json")
    assert result.exit_code == 2 and "the report is the input file" in one_error_line(result)
    assert scene.read_text() == text and not (folder / "y.h5").exists()


# --------------------------------------------------------------------------- outputs a command cannot write
@pytest.mark.parametrize("name", ["x.usdc", "x.txt", "x", "x.obj"])
def test_cook_output_suffix_is_a_usage_error(tmp_path, name):
    result = run("cook", CAPE, "-o", tmp_path / name)
    assert result.exit_code == 2
    assert "NAME.fabric.h5" in one_error_line(result)
    assert not (tmp_path / name).exists()


@pytest.mark.parametrize("args", [["-o", "x.abc"], ["-o", "x.h5", "--report", "r.toml"], ["--bogus"], ["-o", "x.h5", "--frames", "1:1e23"]])
def test_bake_usage_errors_are_one_line_exit_2(folder, args):
    os.chdir(folder)
    result = run("bake", folder / "scene.toml", *args)
    assert result.exit_code == 2
    one_error_line(result)
    assert not (folder / "x.h5").exists()


# --------------------------------------------------------------------------- settings that cannot be meant
@pytest.mark.parametrize("setting,expected", [
    (["--set", "solver.frequency=1e9", "--dry-run"], "iterations per frame, beyond the 1,000,000"),
    (["--set", "solver.frequency=1e300", "--dry-run"], "beyond the 1,000,000"),
    (["--set", "solver.frequency=1e999", "--dry-run"], "give a finite number"),
    (["--frames", "1:9223372036854775807", "-o", "null"], "beyond the 100,000,000"),
    (["--frames", "1:2000000", "-o", "null"], "limit 1,000,000"),
    (["--set", "solver.frequency=960000", "-o", "null"], "iterations per frame (limit 20,000)"),
    (["--set", "scene.fps=1e300", "-o", "null"], "is not a frame rate"),
])
def test_absurd_settings_are_refused_at_once(folder, setting, expected):
    started = time.perf_counter()
    result = run("bake", folder / "scene.toml", *setting)
    assert time.perf_counter() - started < 30  # refused up front, not after hours
    assert result.exit_code == 1
    assert expected in one_error_line(result)


def test_force_lets_a_soft_limit_through(folder):
    result = run("bake", folder / "scene.toml", "--set", "solver.frequency=960000", "--dry-run", "--force", "--frames", "1:2")
    assert result.exit_code == 0, result.stderr
    assert "40000 iterations per frame" in result.stdout


def test_dry_run_calibration_is_bounded(folder):
    started = time.perf_counter()
    result = run("bake", folder / "scene.toml", "--set", "solver.frequency=400000", "--dry-run", "--force")
    assert result.exit_code == 0, result.stderr
    assert time.perf_counter() - started < 30


def test_cache_larger_than_the_free_disk_is_refused(folder, monkeypatch):
    import shutil

    monkeypatch.setattr(shutil, "disk_usage", lambda path: shutil._ntuple_diskusage(10**6, 10**6 - 1000, 1000))
    result = run("bake", folder / "scene.toml", "-o", folder / "x.h5", "--set", 'output.compression="none"')
    assert result.exit_code == 1
    assert "free" in one_error_line(result) and "--force" in result.stderr
    assert not (folder / "x.h5").exists()


# --------------------------------------------------------------------------- messages
def test_set_typos_blame_the_command_line_and_suggest(folder):
    result = run("bake", folder / "scene.toml", "-o", "null", "--set", "solver.frequencyy=3")
    line = one_error_line(result)
    assert line.startswith("Error: --set solver.frequencyy=3:") and "did you mean 'frequency'?" in line
    result = run("bake", folder / "scene.toml", "-o", "null", "--set", "cloth.shet.material=denim")
    assert "the scene has no [cloth.shet]; did you mean 'sheet'?" in one_error_line(result)
    result = run("bake", folder / "scene.toml", "-o", "null", "--set", "cloth.sheet.material.vertical.stifness=1")
    assert "did you mean 'stiffness'?" in one_error_line(result)


def test_a_scene_typo_names_the_file_once(folder):
    scene = folder / "scene.toml"
    scene.write_text(scene.read_text().replace('preset = "preview"', 'preset = "preview"\nfrequncy = 3'))
    line = one_error_line(run("bake", scene, "-o", "null"))
    assert line.count("scene.toml") == 1 and "did you mean 'frequency'?" in line


@pytest.mark.parametrize("kind", ["fabric", "cache", "mesh"])
def test_a_file_of_another_kind_given_as_scene_says_so(folder, kind):
    path = {"fabric": folder / "sheet.fabric.h5", "cache": folder / "c.usdc", "mesh": CAPE}[kind]
    if kind == "cache":
        assert run("bake", folder / "scene.toml", "-o", path).exit_code == 0
    line = one_error_line(run("bake", path, "-o", "null"))
    assert "not a scene" in line


def test_control_characters_from_input_are_escaped(tmp_path):
    bad = tmp_path / "bad.obj"
    bad.write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \r\x1b[2J\x07 3\n")
    result = run("cook", bad, "-o", tmp_path / "x.fabric.h5")
    assert result.exit_code == 1
    line = one_error_line(result)
    assert "\r" not in line and "\x1b" not in line and "\x07" not in line


# --------------------------------------------------------------------------- USD input
def _usda(tmp_path, name, replace=None, insert=None) -> Path:
    text = SKIRT.read_bytes()
    if replace:
        text = text.replace(*replace)
    if insert:
        at = text.find(b"def Mesh")
        text = text[:at] + insert + text[at:]
    path = tmp_path / name
    path.write_bytes(text)
    return path


def test_usd_mesh_problems_are_one_line(tmp_path):
    cases = {
        "bytes.usda": (None, b"\xff\xfe\x80 garbage\r\n", "not UTF-8"),
        "upx.usda": ((b'upAxis = "Y"', b'upAxis = "X"'), None, "upAxis is 'X'"),
        "counts.usda": ((b"int[] faceVertexCounts = [", b"int[] faceVertexCounts = [5, "), None, "faceVertexCounts add up to"),
    }
    for name, (replace, insert, expected) in cases.items():
        path = _usda(tmp_path, name, replace, insert)
        result = run("cook", path, "-o", tmp_path / "x.fabric.h5")
        assert result.exit_code == 1, name
        assert expected in one_error_line(result), name


def test_unresolved_usd_reference_is_one_warning_line(tmp_path):
    path = _usda(tmp_path, "ref.usda", insert=b'def Xform "Broken" (\n    prepend references = @missing_asset.usda@\n)\n{\n}\n')
    out = tmp_path / "x.fabric.h5"
    proc = subprocess.run([sys.executable, "-m", "clothtool", "cook", str(path), "--preset", "garment", "-o", str(out)],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("missing_asset.usda") == 1 and "_ReportErrors" not in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "clothtool", "cook", str(path), "--strict", "-o", str(tmp_path / "y.fabric.h5")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_inspect_of_a_large_usdc_under_an_address_space_limit(tmp_path):
    """A crate file is memory-mapped by default; under ulimit -v that crashed pxr."""
    from clothtool.io.cache import CacheHeader, CacheOptions, ClothTopology, FrameData
    from clothtool.io.usdcache import UsdCacheWriter

    points = np.zeros((250_000, 3), np.float32)
    cloth = ClothTopology("c", points, np.array([3], np.int32), np.array([0, 1, 2], np.int32))
    path = tmp_path / "big.usdc"
    with UsdCacheWriter(path, CacheOptions(save_every=50)) as writer:  # 600 MB
        writer.write_header(CacheHeader(24.0, 1, 200, 1.0, "Y", (cloth,), attributes=frozenset()))
        for frame in range(1, 201):
            writer.write_frame(FrameData(frame, (points + frame,)))
        writer.commit()

    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (1400 << 20, 1400 << 20))

    env = {k: v for k, v in os.environ.items() if k != "USDC_USE_PREAD"}
    proc = subprocess.run([sys.executable, "-m", "clothtool", "inspect", str(path)], capture_output=True, text=True,
                          timeout=300, preexec_fn=limit, env=env)
    assert proc.returncode == 0, proc.stderr
    assert "complete" in proc.stdout and "200 written" in proc.stdout


def test_gltf_buffer_outside_its_folder_is_refused_without_library_hints(tmp_path):
    import json

    import trimesh

    mesh = grid(3, 3, 0.1, plane="XZ")
    files = trimesh.Trimesh(mesh.vertex_pos, mesh.face_vertex_indices.reshape(-1, 3), process=False).export(file_type="gltf")
    gltf = json.loads(files["model.gltf"])
    gltf["buffers"][0]["uri"] = "../../../etc/hostname"
    (tmp_path / "climb.gltf").write_text(json.dumps(gltf))
    result = run("cook", tmp_path / "climb.gltf", "-o", tmp_path / "x.fabric.h5")
    assert result.exit_code == 1
    line = one_error_line(result)
    assert "points outside the file's folder" in line and "FilePathResolver" not in line and line.count(str(tmp_path)) == 1
