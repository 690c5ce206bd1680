"""CliRunner tests for `clothtool cook` and `clothtool inspect`: every option, every bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.io.fabric_file import read_fabric

from tests.conftest import EXAMPLES

SKIRT = EXAMPLES / "skirt" / "skirt.usda"
CAPE = EXAMPLES / "cape" / "cape.obj"


def run(*args):
    result = CliRunner().invoke(main, [str(a) for a in args])
    return result


def write_obj(path, text):
    path.write_text(text)
    return path


SQUARE_OBJ = """v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
f 1 2 3 4
"""


def test_cook_the_example_skirt_with_the_garment_preset(out_dir):
    out = out_dir / "skirt.fabric.h5"
    result = run("cook", SKIRT, "--preset", "garment", "-o", out)
    assert result.exit_code == 0, result.output
    fabric = read_fabric(out)
    assert fabric.particle_count == 48 * 20  # the UV seam column is welded away
    assert fabric.pinned.sum() == 48  # the waistband
    assert "vertical" in result.output and "lower bound" in result.output
    assert "welded     20 coincident vertices" in result.output


def test_cook_json_summary(out_dir):
    out = out_dir / "cape.fabric.h5"
    result = run("cook", CAPE, "--pin-attr", "color_r", "--tethers", "euclidean", "-o", out, "--json")
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["particles"] == 33 * 28 and summary["pinned"] == 33
    assert summary["tethers_per_particle"] == 1 and summary["validation"] == "ok"
    assert {p["type"] for p in summary["phases"]} == {"vertical", "horizontal", "shearing", "bending"}


def test_every_cook_option(out_dir, tmp_path):
    pins = tmp_path / "pins.txt"
    pins.write_text("245 246\n247  # three vertices of ring 5 (file indices)\n")
    out = out_dir / "opts.fabric.h5"
    result = run(
        "cook", SKIRT, "-o", out, "--weld", "1e-5", "--meters-per-unit", "0.001", "--up-axis", "Y",
        "--hang-direction", "0,-1,0", "--no-recover-quads", "--no-shearing", "--bending",
        "--tethers", "geodesic", "--tether-anchors", "2", "--pin-attr", "pin", "--pin-threshold", "0.9",
        "--pin-box", "-0.05,0.4,-0.05,0.05,0.5,0.05", "--pin-file", pins,
        "--max-distance-attr", "maxdist", "--max-distance-range", "0,0.2", "--stiffness-attr", "maxdist",
        "--virtual-particles", "3", "--json",
    )
    assert result.exit_code == 0, result.output
    fabric = read_fabric(out)
    summary = json.loads(result.stdout)
    assert fabric.meters_per_unit == 0.001
    assert "shearing" not in {p["type"] for p in summary["phases"]}
    assert fabric.tethers_per_particle == 2
    assert fabric.pinned.sum() == 48 + 3  # waistband + the three listed vertices (box is empty)
    assert np.isfinite(fabric.particle_max_distance).all() and fabric.particle_max_distance.max() == pytest.approx(0.2)
    assert fabric.constraint_stiffness.min() < 1.0
    assert fabric.virtual_particles.shape[0] == 3 * fabric.triangles.shape[0]
    options = json.loads(fabric.cook_options)
    assert options["pin_file"]["name"] == "pins.txt" and "/" not in json.dumps(options["pin_file"])
    # in millimetres the skirt is about 1 mm across: the size warning shows up on stderr
    assert "check --meters-per-unit" in result.stderr


def test_preset_path_and_override(out_dir, tmp_path):
    preset = tmp_path / "mine.toml"
    preset.write_text('pin_attr = "pin"\nvirtual_particles = 1\n')
    out = out_dir / "p.fabric.h5"
    result = run("cook", SKIRT, "--preset", preset, "--virtual-particles", "0", "-o", out)
    assert result.exit_code == 0, result.output
    fabric = read_fabric(out)
    assert fabric.pinned.sum() == 48 and fabric.virtual_particles.shape[0] == 0


def test_recooking_is_byte_identical(out_dir):
    a, b = out_dir / "a.fabric.h5", out_dir / "b.fabric.h5"
    assert run("cook", CAPE, "--pin-attr", "color_r", "-o", a).exit_code == 0
    assert run("cook", CAPE, "--pin-attr", "color_r", "-o", b).exit_code == 0
    assert a.read_bytes() == b.read_bytes()


def test_inspect_text_and_json(out_dir):
    out = out_dir / "cape.fabric.h5"
    assert run("cook", CAPE, "--pin-attr", "color_r", "-o", out).exit_code == 0
    text = run("inspect", out)
    assert text.exit_code == 0 and "validation ok" in text.output and "924 (33 pinned)" in text.output
    data = json.loads(run("inspect", out, "--json").stdout)
    assert data["kind"] == "fabric" and data["constraints"] == sum(p["constraints"] for p in data["phases"])


@pytest.mark.parametrize(
    "setup, args, message",
    [
        (None, ["cook", "missing.obj"], "missing.obj: file not found"),
        ("bad.xyz", ["cook", "{in}"], "unknown"),
        ("empty.obj", ["cook", "{in}"], "no faces"),
        ("nan.obj", ["cook", "{in}"], "vertex 1 has a NaN"),
        ("range.obj", ["cook", "{in}"], "references vertex 9"),
        ("square.obj", ["cook", "{in}", "--tethers", "geodesic"], "needs pinned particles"),
        ("square.obj", ["cook", "{in}", "--pin-attr", "weight"], "does not have"),
        ("square.obj", ["cook", "{in}", "--preset", "nonesuch"], "available cook presets: coarse, garment"),
        ("square.obj", ["cook", "{in}", "--virtual-particles", "2"], "use one of 0, 1, 3, 4"),
        ("nonmanifold.obj", ["cook", "{in}"], "non-manifold"),
        ("dup.obj", ["cook", "{in}", "--strict"], "duplicate earlier faces"),
        ("flipped.obj", ["cook", "{in}", "--strict"], "wound opposite"),
    ],
)
def test_bad_input_gives_one_line_exit_1_and_no_output(tmp_path, out_dir, setup, args, message):
    contents = {
        "bad.xyz": "hello",
        "empty.obj": "v 0 0 0\n",
        "nan.obj": "v 0 0 0\nv nan 0 0\nv 1 1 0\nf 1 2 3\n",
        "range.obj": "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 10\n",
        "square.obj": SQUARE_OBJ,
        "nonmanifold.obj": "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 1 1 1\nf 1 2 3\nf 1 3 4\nf 1 3 5\n",
        "dup.obj": SQUARE_OBJ + "f 2 3 4 1\n",
        "flipped.obj": "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 4 3\n",
    }
    source = tmp_path / (setup or "missing.obj")
    if setup:
        source.write_text(contents[setup])
    out = out_dir / "x.fabric.h5"
    argv = [a.replace("{in}", str(source)) for a in args] + ["-o", str(out)]
    if setup is None:
        argv[1] = str(tmp_path / "missing.obj")
    result = run(*argv)
    assert result.exit_code == 1, result.output
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: ") and message in lines[0], result.output
    assert "Traceback" not in result.output
    assert not out.exists() and not list(out_dir.iterdir())


def test_repairs_are_warnings_without_strict(tmp_path, out_dir):
    source = write_obj(tmp_path / "dup.obj", SQUARE_OBJ + "f 2 3 4 1\n")
    out = out_dir / "x.fabric.h5"
    result = run("cook", source, "-o", out)
    assert result.exit_code == 0
    assert "repaired: faces 1 duplicate earlier faces" in result.output
    assert out.exists()


def test_output_directory_must_exist(tmp_path):
    result = run("cook", CAPE, "-o", tmp_path / "nope" / "x.fabric.h5")
    assert result.exit_code == 1 and "does not exist" in result.output


def test_inspect_bad_files(tmp_path):
    assert run("inspect", tmp_path / "none.fabric.h5").exit_code == 1
    junk = tmp_path / "junk.fabric.h5"
    junk.write_bytes(b"\x89HDF\r\n" + b"0" * 100)
    result = run("inspect", junk)
    assert result.exit_code == 1 and "Traceback" not in result.output


def test_usage_errors_exit_2():
    assert run("cook").exit_code == 2
    assert run("cook", CAPE).exit_code == 2  # -o is required
    assert run("cook", CAPE, "-o", "x.h5", "--pin-box", "1,2").exit_code == 2
