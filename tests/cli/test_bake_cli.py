"""CliRunner tests for `clothtool bake`: outputs, options, reports, and every bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.cache import read_cache
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid

SCENE = """
version = 1
[scene]
fps = 30.0
frames = [1, 6]
[solver]
preset = "preview"
[output]
attributes = ["velocities", "stats"]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
"""


@pytest.fixture
def scene_dir(tmp_path: Path) -> Path:
    folder = tmp_path / "scene"
    folder.mkdir()
    # a horizontal sheet pinned along its x = 0 edge: it swings down
    fabric = cook_fabric(grid(8, 8, 0.05, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 1))).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "scene.toml").write_text(SCENE)
    return folder


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.mark.parametrize("suffix", [".usdc", ".usda", ".h5"])
def test_bake_writes_a_readable_cache_and_is_byte_identical(scene_dir, out_dir, suffix):
    first, second = out_dir / f"a{suffix}", out_dir / f"b{suffix}"
    for path in (first, second):
        result = run("bake", scene_dir / "scene.toml", "-o", path)
        assert result.exit_code == 0, result.output
    assert first.read_bytes() == second.read_bytes()
    with read_cache(first) as cache:
        assert cache.frames == [1, 2, 3, 4, 5, 6]
        rest, last = cache.points("sheet", 1), cache.points("sheet", 6)
        assert rest.shape == (64, 3) and np.isfinite(last).all()
        edge = rest[:, 0] < 0.01
        np.testing.assert_array_equal(last[edge], rest[edge])  # pinned particles stay put
        assert last[~edge, 1].mean() < rest[~edge, 1].mean() - 0.01  # the rest fell
    assert sorted(p.name for p in out_dir.iterdir()) == sorted([first.name, second.name])  # no temporaries


def test_report_json_html_profile_and_stdout_json(scene_dir, out_dir):
    report = out_dir / "report.json"
    html = out_dir / "report.html"
    result = run("bake", scene_dir / "scene.toml", "-o", "null", "--report", report, "--profile")
    assert result.exit_code == 0, result.output
    data = json.loads(report.read_text())
    assert data["status"] == "ok" and data["frames"]["simulated"] == 5
    assert data["stages"] == ["integrate", "wind", "tethers", "fabric"]
    assert {"wall_s", "cpu_s", "jit_warm_up_s", "frames_per_second", "particle_iterations_per_second"} <= set(data["timing"])
    frame = data["per_frame"][0]["cloths"]["sheet"]
    # a flat sheet has no edge within 45 degrees of the hang direction: no vertical phase
    assert {"horizontal", "shearing", "bending"} == set(frame["strain"])
    assert {"max", "mean", "p99"} == set(frame["strain"]["horizontal"])
    assert frame["finite"] and "tether_stretch" in frame and "kinetic_energy" in frame
    assert "jit warm-up" in result.output and "fabric" in result.output and "ms/frame" in result.output
    assert str(Path.cwd()) not in report.read_text()  # no absolute paths
    assert run("bake", scene_dir / "scene.toml", "-o", "null", "--report", html).exit_code == 0
    text = html.read_text()
    assert text.startswith("<!DOCTYPE html>") and text.count("<svg") == 3
    out = run("bake", scene_dir / "scene.toml", "-o", "null", "--json")
    assert json.loads(out.stdout)["scene"] == "scene"


def test_set_and_frames_overrides(scene_dir):
    result = run(
        "bake", scene_dir / "scene.toml", "-o", "null", "--json", "--frames", "1:3",
        "--set", "solver.frequency=300", "--set", "cloth.sheet.material=silk",
        "--set", "cloth.sheet.material.damping=0.3",
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["frames"]["simulated"] == 2 and data["iterations_per_frame"] == 10
    assert data["solver"]["frequency"] == 300.0


def test_dry_run_prints_the_plan_and_writes_nothing(scene_dir, out_dir):
    result = run("bake", scene_dir / "scene.toml", "--dry-run", "--json")
    assert result.exit_code == 0, result.output
    plan = json.loads(result.stdout)
    assert plan["cloths"]["sheet"]["stages"] == ["integrate", "wind", "tethers", "fabric"]
    assert plan["iterations_per_frame"] == 4 and plan["estimated_bake_s"] > 0
    assert list(out_dir.iterdir()) == []
    assert "estimated bake time" in run("bake", scene_dir / "scene.toml", "--dry-run").output


def test_compression_and_save_every_options(scene_dir, out_dir):
    for compression in ("gzip", "lzf", "none"):
        path = out_dir / f"{compression}.h5"
        assert run("bake", scene_dir / "scene.toml", "-o", path, "--compression", compression).exit_code == 0
    assert run("bake", scene_dir / "scene.toml", "-o", out_dir / "s.usdc", "--save-every", "2").exit_code == 0


def test_unstable_bake_keeps_a_partial_file_and_exits_1(scene_dir, out_dir):
    out = out_dir / "shot.usdc"
    report = out_dir / "report.json"
    # a tiny speed limit makes the falling cloth "unstable" on the first simulated frame
    result = run("bake", scene_dir / "scene.toml", "-o", out, "--set", "solver.max_speed=0.001", "--report", report)
    assert result.exit_code == 1
    assert "unstable at frame 2" in result.output and "cloth 'sheet' particle" in result.output
    assert not out.exists() and (out_dir / "shot.partial.usdc").exists()
    data = json.loads(report.read_text())
    assert data["status"] == "unstable" and data["partial_output"] == "shot.partial.usdc"
    with read_cache(out_dir / "shot.partial.usdc") as cache:
        assert cache.frames == [1]


def bad_scene(folder: Path, text: str) -> Path:
    path = folder / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    "text, message",
    [
        ("[scene\nfps = 24", "malformed TOML"),
        (SCENE.replace("fps = 30.0", "fps = 0.0"), "key 'fps' = 0 must be positive"),
        (SCENE.replace("fps = 30.0", "fps = -24.0"), "must be positive"),
        (SCENE.replace("frames = [1, 6]", "frames = [6, 1]"), "runs backwards"),
        (SCENE.replace("[scene]", "[scene]\nmeters_per_unit = -1.0"), "meters_per_unit"),
        (SCENE.replace("[scene]", "[scene]\nmeters_per_unit = \"cm\""), "meters_per_unit"),
        (SCENE.replace('preset = "preview"', 'preset = "nope"'), "available solver presets: explicit, implicit, physical, preview, production, reference"),
        (SCENE.replace('material = "cotton"', 'material = "tweed"'), "available material presets: cotton, denim, jersey, leather, silk"),
        (SCENE.replace("sheet.fabric.h5", "missing.fabric.h5"), "fabric file not found"),
        (SCENE.replace('fabric = "sheet.fabric.h5"', 'mesh = "missing.obj"'), "missing.obj: file not found"),
        (SCENE.replace("[solver]", "[solver]\nfrequncy = 10.0"), "unknown key 'frequncy'; allowed keys: frequency"),
        (SCENE + "\n[wheather]\nx = 1\n", "unknown top-level key 'wheather'"),
        (SCENE.replace("[output]", "[output]\ncompression = \"zip\""), "compression"),
        (SCENE.replace("[solver]", "[solver]\nfabric_parallel_threshold = 0"), "key 'fabric_parallel_threshold' must be at least 1"),
    ],
)
def test_bad_scene_gives_one_line_exit_1_and_writes_nothing(scene_dir, out_dir, text, message):
    path = bad_scene(scene_dir, text)
    out = out_dir / "shot.usdc"
    result = run("bake", path, "-o", out)
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: ") and message in lines[0], result.output
    assert list(out_dir.iterdir()) == []


def test_malformed_toml_names_the_line(scene_dir, out_dir):
    path = bad_scene(scene_dir, "[scene]\nfps = 24\nframes = [1,\n")
    result = run("bake", path, "-o", out_dir / "x.h5")
    assert result.exit_code == 1 and "at line 3" in result.output and "frames = [1," in result.output


def test_output_problems(scene_dir, tmp_path):
    scene = scene_dir / "scene.toml"
    assert "does not exist" in run("bake", scene, "-o", tmp_path / "nope" / "x.usdc").output
    assert "cannot be written as '.abc'" in run("bake", scene, "-o", tmp_path / "x.abc").output
    assert "use .json or .html" in run("bake", scene, "-o", "null", "--report", tmp_path / "r.txt").output
    assert run("bake", scene).exit_code == 2  # no -o and no --dry-run
    assert run("bake", scene, "-o", "null", "--frames", "1-3").exit_code == 2
    assert "scene file not found" in run("bake", tmp_path / "none.toml", "-o", "null").output


def test_explicit_integrator_refuses_an_unstable_step_unless_forced(scene_dir, out_dir):
    out = out_dir / "x.h5"
    refused = run("bake", scene_dir / "scene.toml", "-o", out, "--set", 'solver.integrator="explicit"')
    assert refused.exit_code == 1
    assert "explicit integration is unstable at h =" in refused.output and "frequency >=" in refused.output
    assert list(out_dir.iterdir()) == []
    forced = run("bake", scene_dir / "scene.toml", "-o", "null", "--set", 'solver.integrator="explicit"', "--force", "--json")
    # forced far beyond the limit the bake blows up: caught as unstable, not a traceback
    assert forced.exit_code == 1 and "unstable at frame" in forced.output and "Traceback" not in forced.output


@pytest.mark.parametrize("preset", ["implicit", "physical"])
def test_other_solvers_bake_through_the_cli(scene_dir, preset):
    result = run("bake", scene_dir / "scene.toml", "-o", "null", "--set", f'solver.preset="{preset}"', "--json")
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["status"] == "ok" and data["solver"]["integrator"] == ("implicit" if preset == "implicit" else "pbd")
    if preset == "implicit":
        assert "cg_iterations" in json.dumps(data["per_frame"][0]["cloths"]["sheet"])
