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
