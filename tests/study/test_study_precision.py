"""study: every bake in the precision asked for, the round-off floor, and time to a target error.

The floor is checked on the README's swing scene (examples/sheet/swing.toml, XPBD, its first
quarter second), where float32 state stops converging after 1536 Hz (g h^2 nears a float32 ulp
of the sheet's height) while float64 keeps converging; time-to-error against closed forms of
the log-log interpolation.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import ClothtoolError
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid
from clothtool.study import StudyOptions, roundoff, run_study
from clothtool.study.output import format_table, write_study
from clothtool.study.sweep import Sweep
from clothtool.study.target import interpolate_time, time_to_error
from tests.conftest import EXAMPLES

PHYSICAL = ('solver.preset="physical"',)


def row(family: str, label: str, time_: float, error: float, failed: str | None = None) -> dict:
    return {"family": family, "label": label, "wall_s_per_simulated_s": time_, "position_rms": error, "failed": failed}


# ---------------------------------------------------------------- time to a target error
def test_interpolation_is_exact_on_a_power_law():
    # e = 1e-2 t^-2 through (1, 1e-2) and (2, 2.5e-3): e = 5e-3 at t = sqrt(2)
    assert interpolate_time(1.0, 1e-2, 2.0, 2.5e-3, 5e-3) == pytest.approx(math.sqrt(2.0), rel=1e-12)
    # e = 0.3 t^-1 through (0.5, 0.6) and (4, 0.075): e = 0.1 at t = 3
    assert interpolate_time(0.5, 0.6, 4.0, 0.075, 0.1) == pytest.approx(3.0, rel=1e-12)


def test_time_to_error_picks_the_cheapest_run_per_family():
    rows = [
        row("a", "60", 1.0, 1e-2), row("a", "120", 2.0, 2.5e-3), row("a", "240", 4.0, 6e-4),
        # non-monotone: the 480 run is cheaper than the 240 one by time and already good enough
        row("b", "240", 8.0, 1e-4), row("b", "480", 3.0, 4e-3), row("b", "60", 1.5, 9e-2, failed="unstable"),
        row("c", "60", 1.0, 0.5), row("c", "120", 2.0, 0.2),
    ]
    a, b, c = time_to_error(rows, "position_rms", 5e-3)
    assert (a["run"], a["bound"], a["run_wall_s_per_simulated_s"]) == ("120", "interpolated", 2.0)
    assert a["wall_s_per_simulated_s"] == pytest.approx(math.sqrt(2.0), rel=1e-12)
    # the failed run does not count: b's cheapest usable run meets the target, an upper bound
    assert (b["run"], b["bound"], b["wall_s_per_simulated_s"]) == ("480", "at most", 3.0)
    assert not c["reached"] and c["best_error"] == 0.2 and c["wall_s_per_simulated_s"] is None


# ---------------------------------------------------------------- precision and the floor
@pytest.fixture(scope="module")
def swing_precision_study():
    options = StudyOptions(
        sweeps=(Sweep.parse("solver.frequency=384,1536,6144"), Sweep.parse("solver.precision=float32,float64")),
        repeats=1, overrides=PHYSICAL, reference=PHYSICAL, reference_frequency=24576.0, frames=(1, 7),
        target_error=1e-3,
    )
    return run_study(EXAMPLES / "sheet" / "swing.toml", options)


def test_float32_rows_show_the_round_off_floor_and_float64_rows_converge(swing_precision_study):
    result = swing_precision_study
    rows = {(r["precision"], r["label"]): r for r in result.rows}
    assert [r["precision"] for r in result.rows] == ["float32"] * 3 + ["float64"] * 3
    # a sweep asked for float64: the reference runs in it, and says so
    assert result.reference["precision"] == "float64" and result.reference["roundoff_source"] == roundoff.ESTIMATED
    f64 = [rows["float64", f]["position_rms"] for f in ("384", "1536", "6144")]
    assert f64[0] > f64[1] > f64[2] and not any(rows["float64", f]["at_floor"] for f in ("384", "1536", "6144"))
    for f in ("384", "1536", "6144"):
        assert rows["float64", f]["roundoff"]["position_rms"] < 1e-9  # eps64 |x| N^2 / size
        assert rows["float32", f]["roundoff_source"] == roundoff.MEASURED
    f32_roundoff = [rows["float32", f]["roundoff"]["position_rms"] for f in ("384", "1536", "6144")]
    # float32 round-off grows with the iteration count (measured 1e-5, 3e-4, 6e-3 of the size) ...
    assert f32_roundoff[0] < f32_roundoff[1] < f32_roundoff[2]
    # ... until it is the error: at 6144 Hz the float32 run is worse than at 1536 Hz and at its floor
    slow, fast = rows["float32", "1536"], rows["float32", "6144"]
    assert fast["position_rms"] > slow["position_rms"] and fast["at_floor"] and not rows["float32", "384"]["at_floor"]
    assert fast["position_rms"] > 10 * rows["float64", "6144"]["position_rms"]
    # the float32 run's measured round-off is its distance from the float64 run of the same
    # setting, which the sweep baked: so it bounds the two runs' error difference
    assert abs(fast["position_rms"] - rows["float64", "6144"]["position_rms"]) <= fast["roundoff"]["position_rms"] * (1 + 1e-9)
    table = format_table(result)
    line = next(t for t in table.splitlines() if t.strip().startswith("6144") and "float32" in t)
    assert line.split()[-5].endswith("#") and f"reference: {result.reference['frequency']:g} Hz, float64" in table


def test_time_to_error_on_the_study_picks_the_cheapest_run_and_interpolates(swing_precision_study, out_dir):
    result = swing_precision_study
    target = result.target
    assert target["error"] == 1e-3 and target["metric"] == "position"
    for answer in target["families"]:
        family = sorted((r for r in result.rows if r["family"] == answer["family"]), key=lambda r: r["wall_s_per_simulated_s"])
        good = [r for r in family if r["position_rms"] <= 1e-3]
        assert answer["reached"] == bool(good)
        if not good:
            continue
        assert answer["run"] == good[0]["label"]
        cheaper = [r for r in family if r["wall_s_per_simulated_s"] < good[0]["wall_s_per_simulated_s"]]
        if cheaper:
            t0, e0 = cheaper[-1]["wall_s_per_simulated_s"], cheaper[-1]["position_rms"]
            t1, e1 = good[0]["wall_s_per_simulated_s"], good[0]["position_rms"]
            expected = math.exp(math.log(t0) + (math.log(1e-3 / e0)) / math.log(e1 / e0) * math.log(t1 / t0))
            assert answer["wall_s_per_simulated_s"] == pytest.approx(expected, rel=1e-9)
            assert min(t0, t1) <= answer["wall_s_per_simulated_s"] <= max(t0, t1)
    # float64 reaches 1e-3 of the cloth's size (6144 Hz: ~6e-5); the table, JSON and plot say so
    f64 = next(a for a in target["families"] if a["family"] == "precision=float64")
    assert f64["reached"]
    written = {p.name for p in write_study(result, out_dir / "study")}
    assert {"table.json", "plot.png", "plot.svg"} <= written
    text = (out_dir / "study" / "table.txt").read_text()
    assert "time to reach position error <= 0.001" in text and "precision=float64:" in text
    assert '"target"' in (out_dir / "study" / "table.json").read_text()
    assert "time to target" in (out_dir / "study" / "plot.svg").read_text()


@pytest.fixture
def small_scene(tmp_path: Path) -> Path:
    folder = tmp_path / "scene"
    folder.mkdir()
    fabric = cook_fabric(grid(6, 6, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1), tethers="none")).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    (folder / "swing.toml").write_text(
        '[scene]\nfps = 24.0\nframes = [1, 4]\n[solver]\npreset = "physical"\nprecision = "float32"\n'
        '[cloth.sheet]\nfabric = "sheet.fabric.h5"\n'
        'material = { preset = "cotton", damping = 0.0, drag_coefficient = 0.0, lift_coefficient = 0.0 }\n'
        'rotate_euler = [60.0, 0.0, 0.0]\ntranslate = [0.0, 40.0, 0.0]\n'
    )
    return folder / "swing.toml"


def test_a_float32_scene_gets_a_float32_reference_with_its_round_off_measured(small_scene):
    options = StudyOptions(sweeps=(Sweep.parse("solver.frequency=96,1536"),), repeats=1, reference_frequency=3072.0,
                           reference_doublings=0)
    result = run_study(small_scene, options)
    assert result.reference["precision"] == "float32" and result.reference["roundoff_source"] == roundoff.MEASURED
    # 40 m from the origin a float32 ulp is 3.8e-6 m: 3072 Hz's g h^2 (1.0e-6 m) rounds away
    assert result.reference["roundoff"] > 1e-3
    assert all(r["precision"] == "float32" and r["roundoff_source"] == roundoff.MEASURED for r in result.rows)
    # every floor includes the reference's round-off, so the finer run is at the floor
    assert all(r["floor"] >= result.reference["roundoff"] for r in result.rows)
    assert result.rows[-1]["at_floor"]
    assert "reference: 3072 Hz, float32" in format_table(result)


def test_a_bad_target_error_is_one_clear_error(small_scene):
    options = StudyOptions(sweeps=(Sweep.parse("solver.frequency=96"),), repeats=1, target_error=-1.0)
    with pytest.raises(ClothtoolError, match="--target-error -1: give a positive error"):
        run_study(small_scene, options)
