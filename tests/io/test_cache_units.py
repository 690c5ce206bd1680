"""Caches say what their numbers mean: a ``units`` attribute on every HDF5 dataset (customData
on USD's custom attributes), the pin map as a named ``pin`` primvar, and velocities in world
space; older files without units still read."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from pxr import Usd
from test_cache_roundtrip import make_header, write_cache

from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.cache import read_cache
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid

SCENE = """
version = 1
[scene]
fps = 30.0
frames = [1, 5]
meters_per_unit = 0.01
[solver]
preset = "preview"
[output]
attributes = ["velocities", "stats", "rest", "colliders"]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
[collider.ball]
kind = "sphere"
center = [20.0, -30.0, 20.0]
radius = 10.0
"""


def _datasets(f) -> dict:
    found = {}

    def visit(name, obj):  # returns None: visititems stops at the first other value
        if isinstance(obj, h5py.Dataset):
            found[name] = obj

    f.visititems(visit)
    return found


def test_every_dataset_says_its_units(out_dir):
    path = out_dir / "shot.h5"
    write_cache(path, make_header(), count=3)
    with h5py.File(path, "r") as f:
        datasets = _datasets(f)
        assert len(datasets) > 30
        missing = [name for name, d in datasets.items() if not d.attrs.get("units")]
        assert missing == []
        skirt = f["cloth/skirt"]
        # make_header's scene is in centimetres: lengths say how long a unit is
        assert skirt["P"].attrs["units"] == "scene units (0.01 m)" == skirt["extent"].attrs["units"] == skirt["rest"].attrs["units"]
        assert skirt["v"].attrs["units"] == "scene units per second (0.01 m/s)" and skirt["v"].attrs["frame"] == "world"
        assert skirt["primvars/pin"].attrs["units"] == "1 = pinned, 0 = free"
        assert skirt["primvars/max_distance"].attrs["units"] == "scene units (0.01 m); -1 = unbounded"
        assert skirt["stats/residual"].attrs["units"] == "not specified by the writer"  # a field the writer does not know
        assert f["collider/box/planes"].attrs["units"].endswith("d in scene units (0.01 m)")
        assert f["collider/arm"].attrs["params_units"] == "scene units (0.01 m)"
        assert f["collider/ball/xform"].attrs["units"].startswith("4x4 matrix, row vectors")


@pytest.fixture
def baked(tmp_path: Path) -> Path:
    # a sheet pinned along its x = 0 edge, in centimetres, above a ball
    fabric = cook_fabric(grid(8, 8, 5.0, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.5, 1, 100))).fabric
    write_fabric(fabric, tmp_path / "sheet.fabric.h5")
    (tmp_path / "scene.toml").write_text(SCENE)
    return tmp_path


def _bake(folder: Path, output: Path) -> dict:
    report = output.with_suffix(".json")
    result = CliRunner().invoke(main, ["bake", str(folder / "scene.toml"), "-o", str(output), "--report", str(report)])
    assert result.exit_code == 0, result.output
    return json.loads(report.read_text())


def test_bake_exports_the_pin_map_and_stats_in_the_reports_units(baked, out_dir):
    path = out_dir / "sheet.h5"
    report = _bake(baked, path)
    with h5py.File(path, "r") as f:
        sheet = f["cloth/sheet"]
        assert sorted(sheet["primvars"]) == ["pin"]  # no inverse masses go out
        rest = sheet["rest"][()]
        np.testing.assert_array_equal(sheet["primvars/pin"][()], (rest[:, 0] < 0.5).astype(np.float32))
        stats = sheet["stats"]
        assert stats["max_speed"].attrs["units"] == "m/s" and stats["max_speed"].attrs["frame"] == "cloth"
        assert stats["kinetic_energy"].attrs["units"] == "J"
        assert stats["max_strain"].attrs["units"] == stats["tether_stretch"].attrs["units"] == "fraction (0.01 = 1%)"
        # the cache and the report give the same numbers in the same units
        overall = report["overall"]["sheet"]
        assert stats["max_speed"][()].max() == pytest.approx(overall["max_speed"])
        assert stats["max_strain"][()].max() == pytest.approx(max(s["max"] for s in overall["strain"].values()))
        # velocities are world-space scene units per second: the pinned edge stands still
        v, pin = sheet["v"][-1], sheet["primvars/pin"][()] == 1
        assert np.abs(v[pin]).max() == 0 and np.abs(v[~pin]).max() > 0
        # a falling particle's speed in cm/s is 100 times its speed in m/s
        speeds = np.linalg.norm(sheet["v"][()], axis=2).max(axis=1)
        np.testing.assert_allclose(speeds[1:] / 100, stats["max_speed"][1:], rtol=0.05)


def test_usd_cache_names_the_pin_primvar_and_stat_units(baked, out_dir):
    path = out_dir / "sheet.usdc"
    _bake(baked, path)
    stage = Usd.Stage.Open(str(path))
    sheet = stage.GetPrimAtPath("/Bake/Cloth/sheet")
    pin = sheet.GetAttribute("primvars:clothtool:pin")
    assert pin.IsValid() and not sheet.GetAttribute("primvars:clothtool:inv_mass").IsValid()
    assert pin.GetCustomDataByKey("clothtool:units") == "1 = pinned, 0 = free"
    assert set(np.asarray(pin.Get())) == {0.0, 1.0}
    strain = sheet.GetAttribute("clothtool:stats:max_strain")
    assert strain.GetCustomDataByKey("clothtool:units") == "fraction (0.01 = 1%)"
    speed = sheet.GetAttribute("clothtool:stats:max_speed")
    assert (speed.GetCustomDataByKey("clothtool:units"), speed.GetCustomDataByKey("clothtool:frame")) == ("m/s", "cloth")
    with read_cache(path) as cache:
        assert sorted(cache.header.cloths[0].vertex_primvars) == ["pin"]


def test_a_file_written_before_units_still_reads(out_dir):
    path = out_dir / "old.h5"
    header = make_header()
    write_cache(path, header, count=3)
    with h5py.File(path, "r+") as f:  # as version 1 files were first written: no units, inv_mass
        for dataset in _datasets(f).values():
            for key in ("units", "frame"):
                if key in dataset.attrs:
                    del dataset.attrs[key]
        del f["collider/arm"].attrs["params_units"]
        f.move("cloth/skirt/primvars/pin", "cloth/skirt/primvars/inv_mass")
    with read_cache(path) as cache:
        assert sorted(cache.header.cloths[0].vertex_primvars) == ["inv_mass", "max_distance"]
        np.testing.assert_array_equal(cache.header.cloths[0].vertex_primvars["inv_mass"], header.cloths[0].vertex_primvars["pin"])
        assert cache.frames == [3, 4, 5]
