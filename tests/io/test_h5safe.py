"""The HDF5 link and storage walk shared by the fabric and cache readers (clothtool.io.h5safe)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from clothtool.errors import FormatError
from clothtool.io.h5safe import check_hdf5_file, read_dataset

FIX = "make it again"


def checked(path):
    with h5py.File(path, "r") as f:
        check_hdf5_file(f, path, FIX)


@pytest.fixture
def plain(out_dir):
    path = out_dir / "plain.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("g/data", data=np.arange(6, dtype=np.int32))
        f.create_dataset("g/packed", data=np.zeros(100_000, np.float32), compression="gzip", chunks=(10_000,))
    return path


def test_plain_file_passes(plain):
    checked(plain)


def test_soft_links_that_resolve_pass(plain):
    with h5py.File(plain, "r+") as f:
        f["g/relative"] = h5py.SoftLink("data")  # relative to its group
        f["alias_group"] = h5py.SoftLink("/g")
        f["through_alias"] = h5py.SoftLink("/alias_group/data")  # a soft link inside the path
        f["chain"] = h5py.SoftLink("/through_alias")
    checked(plain)


@pytest.mark.parametrize(
    "links, message",
    [
        ({"dangling": "/g/missing"}, "soft link 'dangling' points at '/g/missing', which does not exist"),
        ({"g/self": "/g/self"}, "soft link 'g/self' is part of a soft-link cycle"),
        ({"a": "/b/x", "b": "/a"}, "soft link 'a' is part of a soft-link cycle"),
        ({"into_data": "/g/data/child"}, "points at '/g/data/child', which does not exist"),
    ],
)
def test_bad_soft_links_are_refused(plain, links, message):
    with h5py.File(plain, "r+") as f:
        for name, target in links.items():
            f[name] = h5py.SoftLink(target)
    with pytest.raises(FormatError, match=message) as info:
        checked(plain)
    assert str(plain) in str(info.value) and FIX in str(info.value)


def test_fill_value_dataset_claiming_more_than_the_file_holds_is_refused(plain):
    with h5py.File(plain, "r+") as f:
        f.create_dataset("g/forged", shape=(10**9,), dtype=np.float64, chunks=(4096,))
    with pytest.raises(FormatError, match=r"dataset 'g/forged' declares shape \(1000000000,\) \(8,000,000,000 bytes\) but the file holds 0 bytes"):
        checked(plain)


def test_highly_compressed_real_data_passes(plain):
    # 100,000 zeros gzip down to a few hundred bytes: within gzip's ~1032:1 limit.
    with h5py.File(plain, "r") as f:
        assert f["g/packed"].id.get_storage_size() * 1100 > f["g/packed"].nbytes
    checked(plain)


def test_string_dataset_is_refused(plain):
    with h5py.File(plain, "r+") as f:
        f["g/text"] = "root:x:0:0"
    with pytest.raises(FormatError, match="dataset 'g/text' has dtype object, not a number type") as info:
        checked(plain)
    assert "root:x" not in str(info.value)


def test_read_dataset_refuses_casts_and_shapes(plain):
    with h5py.File(plain, "r") as f:
        with pytest.raises(FormatError, match="dataset 'g/data' has dtype int32, expected float32"):
            read_dataset(f["g/data"], plain, "g/data", np.float32, 1, FIX)
        with pytest.raises(FormatError, match=r"has shape \(6,\), expected 2 dimensions with last axis 3"):
            read_dataset(f["g/data"], plain, "g/data", np.int32, 2, FIX, width=3)
        with pytest.raises(FormatError, match="'g' is a Group, expected a dataset"):
            read_dataset(f["g"], plain, "g", np.int32, 1, FIX)
        np.testing.assert_array_equal(read_dataset(f["g/data"], plain, "g/data", np.int32, 1, FIX), np.arange(6))
