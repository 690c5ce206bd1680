"""CliRunner tests for `clothtool study`: outputs, families, failures, --append, bad input."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid

SCENE = """
[scene]
fps = 24.0
frames = [1, 5]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = { preset = "cotton", damping = 0.0, drag_coefficient = 0.0, lift_coefficient = 0.0 }
rotate_euler = [60.0, 0.0, 0.0]
"""


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    folder = tmp_path / "scene"
    folder.mkdir()
    fabric = cook_fabric(grid(6, 6, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1), tethers="none")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "swing.toml").write_text(SCENE)
    return folder / "swing.toml"


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_study_writes_table_plot_and_reference(scene, out_dir):
    out = out_dir / "study"
    result = run(
        "study", scene, "--sweep", "solver.frequency=48,96", "--sweep", "solver.stiffness_mode=nvcloth,xpbd",
        "--repeats", "1", "--reference-frequency", "768", "-o", out,
    )
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == [
        "plot.png", "plot.svg", "reference.npz", "table.csv", "table.json", "table.txt",
    ]
    data = json.loads((out / "table.json").read_text())
    assert [(r["family"], r["label"]) for r in data["rows"]] == [
        ("stiffness_mode=nvcloth", "48"), ("stiffness_mode=nvcloth", "96"),
        ("stiffness_mode=xpbd", "48"), ("stiffness_mode=xpbd", "96"),
    ]
    for row in data["rows"]:
        assert row["failed"] is None and row["position_rms"] > 0 and row["wall_s_per_simulated_s"] > 0
    # halving the step brings each family closer to the reference
    for family in ("stiffness_mode=nvcloth", "stiffness_mode=xpbd"):
        coarse, fine = [r["position_rms"] for r in data["rows"] if r["family"] == family]
        assert fine < coarse
    assert data["reference"]["frequency"] >= 768 and "machine" in data and "cpu" in data["machine"]
    rows = list(csv.reader((out / "table.csv").open()))
    assert rows[0][:2] == ["solver.frequency", "solver.stiffness_mode"] and len(rows) == 5
    assert "Pareto front" in result.output and "reference:" in result.output
    assert (out / "plot.png").read_bytes()[:4] == b"\x89PNG"


def test_precision_floor_and_target_error_reach_table_csv_and_json(scene, out_dir):
    out = out_dir / "study"
    result = run(
        "study", scene, "--sweep", "solver.frequency=48,96", "--sweep", "solver.precision=float32,float64",
        "--repeats", "1", "--reference-frequency", "768", "--target-error", "1", "-o", out, "--json",
    )
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert [r["precision"] for r in data["rows"]] == ["float32", "float32", "float64", "float64"]
    assert data["reference"]["precision"] == "float64"
    # an error of 1 (the cloth's size) is reached by the cheapest run of each family
    for answer in data["target"]["families"]:
        family = [r for r in data["rows"] if r["family"] == answer["family"]]
        cheapest = min(family, key=lambda r: r["wall_s_per_simulated_s"])
        assert (answer["run"], answer["bound"]) == (cheapest["label"], "at most")
    rows = list(csv.DictReader((out / "table.csv").open()))
    assert [r["precision"] for r in rows] == ["float32", "float32", "float64", "float64"]
    assert all(float(r["floor"]) > 0 and r["at_floor"] in ("True", "False") for r in rows)
    assert "time to reach position error <= 1" in (out / "table.txt").read_text()


def test_unstable_settings_are_listed_not_dropped_and_append_reuses_the_reference(scene, out_dir):
    out = out_dir / "study"
    first = run("study", scene, "--sweep", "solver.frequency=96", "--repeats", "1", "--reference-frequency", "384", "-o", out)
    assert first.exit_code == 0, first.output
    reference = (out / "reference.npz").read_bytes()
    # the explicit integrator refuses 96 Hz on cotton: a failed row, with the frequency it needs
    second = run(
        "study", scene, "--sweep", "solver.frequency=96", "--sweep", "solver.integrator=explicit",
        "--repeats", "1", "--reference-frequency", "384", "-o", out, "--append", "--json",
    )
    assert second.exit_code == 0, second.output
    rows = json.loads(second.stdout)["rows"]
    assert len(rows) == 2
    failed = [r for r in rows if r["failed"]]
    assert len(failed) == 1 and "needs h <=" in failed[0]["failed"] and failed[0]["family"] == "integrator=explicit"
    assert (out / "reference.npz").read_bytes() == reference  # reused, not baked again
    assert "FAILED integrator=explicit 96" in (out / "table.txt").read_text()


def test_append_refuses_another_reference(scene, out_dir):
    out = out_dir / "study"
    assert run("study", scene, "--sweep", "solver.frequency=96", "--repeats", "1", "--reference-frequency", "384", "-o", out).exit_code == 0
    result = run("study", scene, "--sweep", "solver.frequency=48", "--repeats", "1", "-o", out, "--append",
                 "--reference", "solver.stiffness_mode=xpbd")
    assert result.exit_code == 1 and "--append needs the same scene" in result.output


@pytest.mark.parametrize(
    "args, message",
    [
        (["--sweep", "solver.frequency"], "expected KEY=V1,V2"),
        (["--sweep", "solver.frequncy=60"], "unknown key 'frequncy'"),
        (["--sweep", "solver.frequency=60", "--append"], "--append needs an earlier study"),
        (["--sweep", "solver.frequency=60", "--target-error", "0"], "--target-error 0: give a positive error"),
    ],
)
def test_bad_study_input(scene, out_dir, args, message):
    result = run("study", scene, *args, "--repeats", "1", "-o", out_dir / "study")
    assert result.exit_code == 1 and message in result.output, result.output
    assert "Traceback" not in result.output
