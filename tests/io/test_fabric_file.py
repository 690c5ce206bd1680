"""Fabric files: round trip, byte identity, refusal of foreign, truncated and invalid files."""

from __future__ import annotations

import hashlib

import h5py
import numpy as np
import pytest

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import FormatError
from clothtool.fabric import ARRAY_FIELDS
from clothtool.io.fabric_file import read_fabric, write_fabric
from clothtool.mesh.shapes import grid


def cooked(n=6):
    return cook_fabric(grid(n, n, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1), virtual_particles=3)).fabric


def test_round_trip_keeps_every_field(out_dir):
    fabric = cooked()
    path = out_dir / "cloth.fabric.h5"
    write_fabric(fabric, path)
    back = read_fabric(path)
    for name, _, _ in ARRAY_FIELDS:
        np.testing.assert_array_equal(getattr(back, name), getattr(fabric, name), err_msg=name)
    for name in ("meters_per_unit", "up_axis", "source_sha256", "cook_options"):
        assert getattr(back, name) == getattr(fabric, name)
    np.testing.assert_array_equal(back.hang_direction, fabric.hang_direction)


def test_recooking_gives_identical_bytes(out_dir):
    a, b = out_dir / "a.fabric.h5", out_dir / "b.fabric.h5"
    write_fabric(cooked(40), a)
    write_fabric(cooked(40), b)
    assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()
    assert not list(out_dir.glob(".*"))  # no temporary files left behind


def test_missing_file(out_dir):
    with pytest.raises(FormatError, match="not found"):
        read_fabric(out_dir / "nope.fabric.h5")


def test_truncated_file_is_refused(out_dir):
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked(30), path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(FormatError, match="truncated or damaged"):
        read_fabric(path)


def test_foreign_hdf5_file_is_refused(out_dir):
    path = out_dir / "other.h5"
    with h5py.File(path, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(FormatError, match="not a clothtool fabric"):
        read_fabric(path)


def test_newer_version_is_refused(out_dir):
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked(), path)
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = 99
    with pytest.raises(FormatError, match="version 99 is not supported"):
        read_fabric(path)


def test_invalid_content_is_refused(out_dir):
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked(), path)
    with h5py.File(path, "a") as f:
        f["constraint_indices"][0, 0] = 10_000
    with pytest.raises(FormatError, match="invalid fabric.*constraint_indices"):
        read_fabric(path)


def test_text_file_is_refused(out_dir):
    path = out_dir / "cloth.fabric.h5"
    path.write_text("hello")
    with pytest.raises(FormatError, match="cannot be read as a fabric"):
        read_fabric(path)


def test_a_reordered_fabric_is_version_2_and_keeps_its_particle_order(out_dir):
    fabric = cooked()
    assert fabric.reordered
    path = out_dir / "cloth.fabric.h5"
    write_fabric(fabric, path)
    with h5py.File(path, "r") as f:
        assert int(f.attrs["format_version"]) == 2 and "particle_vertex" in f
    np.testing.assert_array_equal(read_fabric(path).particle_vertex, fabric.particle_vertex)


def test_a_fabric_in_vertex_order_is_written_as_version_1(out_dir):
    fabric = cook_fabric(grid(6, 6, 0.1), CookOptions(tethers="none", reorder=False)).fabric
    path = out_dir / "cloth.fabric.h5"
    write_fabric(fabric, path)
    with h5py.File(path, "r") as f:
        assert int(f.attrs["format_version"]) == 1 and "particle_vertex" not in f
    back = read_fabric(path)
    assert not back.reordered and back.particle_vertex.shape == (0,)


def test_version_1_file_reads_in_vertex_order_even_with_a_stray_dataset(out_dir):
    """A version-1 file has no particle order: a dataset of that name is not read."""
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked(), path)
    with h5py.File(path, "a") as f:
        f.attrs["format_version"] = 1
    assert not read_fabric(path).reordered


def test_version_2_without_particle_order_is_refused(out_dir):
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked(), path)
    with h5py.File(path, "a") as f:
        del f["particle_vertex"]
    with pytest.raises(FormatError, match="dataset 'particle_vertex' is missing"):
        read_fabric(path)


def test_particle_order_that_is_no_permutation_is_refused(out_dir):
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked(), path)
    with h5py.File(path, "a") as f:
        f["particle_vertex"][1] = f["particle_vertex"][0]
    with pytest.raises(FormatError, match="invalid fabric.*particle_vertex.*permutation"):
        read_fabric(path)
