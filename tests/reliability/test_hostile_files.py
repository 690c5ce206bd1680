"""Hostile and broken input files: refused with one line naming the file, the element and the
fix, before any foreign data is read, and without echoing what the file holds.

HDF5 fabrics and caches are built with the library, then edited with h5py into what an
attacker or a broken exporter would hand over (external storage, external links, soft-link
cycles, virtual datasets, forged headers, bad values).
"""

from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import FormatError, MeshError, PresetError, SceneError
from clothtool.io.cache import CacheHeader, CacheOptions, ClothTopology, FrameData, open_cache_writer, read_cache
from clothtool.io.fabric_file import read_fabric, write_fabric
from clothtool.io.h5cache import read_h5_cache
from clothtool.io.meshin import read_mesh
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from clothtool.presets import load_preset

SENTINEL = b"SENTINEL-bytes-of-a-foreign-file"
CLOTH = "skirt"


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def assert_one_line_failure(result, *fragments: str) -> str:
    """Exit 1, one 'Error:' line containing every fragment, no traceback, no sentinel."""
    assert result.exit_code == 1, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), result.output
    assert "Traceback" not in result.output and "internal error" not in result.output
    assert SENTINEL.decode() not in result.output
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


# --------------------------------------------------------------------------- builders
def cooked_fabric(virtual: int = 3):
    return cook_fabric(grid(5, 5, 0.1), CookOptions(pin_box=(-1, -0.01, -1, 1, 1, 1), virtual_particles=virtual)).fabric


@pytest.fixture
def fabric_path(out_dir: Path) -> Path:
    path = out_dir / "cloth.fabric.h5"
    write_fabric(cooked_fabric(), path)
    return path


def cache_header(side: int = 25) -> CacheHeader:
    sheet = grid(side, side, 0.04)
    topology = ClothTopology(CLOTH, sheet.vertex_pos.astype(np.float32), sheet.face_vertex_counts, sheet.face_vertex_indices)
    return CacheHeader(30.0, 1, 4, 1.0, "Y", (topology,), (), frozenset({"velocities", "rest"}))


def write_small_cache(path: Path) -> Path:
    header = cache_header()
    rest = header.cloths[0].rest_pos
    with open_cache_writer(path, CacheOptions()) as writer:
        writer.write_header(header)
        for frame in range(1, 5):
            writer.write_frame(FrameData(frame, (rest + np.float32(0.01 * frame),), (np.zeros_like(rest),)))
        writer.commit()
    return path


@pytest.fixture
def cache_path(out_dir: Path) -> Path:
    return write_small_cache(out_dir / "shot.h5")


@pytest.fixture
def sentinel_file(out_dir: Path) -> Path:
    path = out_dir / "foreign.bin"
    path.write_bytes(SENTINEL * 4096)
    return path


def replace_dataset(path: Path, name: str, **create) -> None:
    with h5py.File(path, "r+") as f:
        del f[name]
        f.create_dataset(name, **create)


def external_storage(path: Path, name: str, target: Path) -> None:
    """Make dataset ``name`` read its bytes from ``target`` (same shape and dtype)."""
    with h5py.File(path, "r+") as f:
        shape, dtype = f[name].shape, f[name].dtype
        del f[name]
        nbytes = int(np.prod(shape)) * dtype.itemsize
        f.create_dataset(name, shape=shape, dtype=dtype, external=[(str(target), 0, nbytes)])


def virtual_dataset(path: Path, name: str, source: Path) -> None:
    """Make dataset ``name`` a virtual dataset mapping dataset 'data' of file ``source``."""
    with h5py.File(path, "r+") as f:
        shape, dtype = f[name].shape, f[name].dtype
        with h5py.File(source, "w") as other:
            other.create_dataset("data", data=np.frombuffer((SENTINEL * 8192)[: int(np.prod(shape)) * dtype.itemsize], dtype).reshape(shape))
        del f[name]
        layout = h5py.VirtualLayout(shape=shape, dtype=dtype)
        layout[...] = h5py.VirtualSource(str(source), "data", shape=shape)
        f.create_virtual_dataset(name, layout)


def external_link(path: Path, name: str, other: Path) -> None:
    with h5py.File(path, "r+") as f:
        with h5py.File(other, "w") as o:
            o[name.rsplit("/", 1)[-1]] = f[name][()]
        del f[name]
        f[name] = h5py.ExternalLink(str(other), "/" + name.rsplit("/", 1)[-1])


def soft_link_cycle(path: Path, group: str = "/") -> None:
    with h5py.File(path, "r+") as f:
        g = f[group]
        g["loop_a"] = h5py.SoftLink(f"{group.rstrip('/')}/loop_b")
        g["loop_b"] = h5py.SoftLink(f"{group.rstrip('/')}/loop_a")


# --------------------------------------------------------------------------- HDF5 escapes
FABRIC_ESCAPES = {
    "external storage": (lambda p, s: external_storage(p, "rest_pos", s), "dataset 'rest_pos' uses external storage"),
    "virtual dataset": (lambda p, s: virtual_dataset(p, "rest_pos", s.with_suffix(".h5")), "dataset 'rest_pos' is a virtual dataset"),
    "external link": (lambda p, s: external_link(p, "triangles", s.with_suffix(".h5")), "link 'triangles' is an external link"),
    "soft-link cycle": (lambda p, s: soft_link_cycle(p), "soft link 'loop_a' is part of a soft-link cycle"),
}


@pytest.mark.parametrize("escape", FABRIC_ESCAPES)
def test_fabric_reaching_outside_itself_is_refused_before_reading(fabric_path, sentinel_file, escape):
    make, message = FABRIC_ESCAPES[escape]
    make(fabric_path, sentinel_file)
    with pytest.raises(FormatError, match=message) as info:
        read_fabric(fabric_path)
    assert str(fabric_path) in str(info.value) and "re-cook it" in str(info.value)
    assert_one_line_failure(run("inspect", fabric_path), message)


def test_fabric_external_storage_is_refused_without_opening_the_target(fabric_path, out_dir):
    # Were the bytes read, HDF5 would fail to open the missing file with its own message.
    external_storage(fabric_path, "rest_pos", out_dir / "does-not-exist.bin")
    with pytest.raises(FormatError, match="dataset 'rest_pos' uses external storage"):
        read_fabric(fabric_path)


def test_bake_never_copies_external_bytes_into_the_cache(fabric_path, sentinel_file, out_dir):
    external_storage(fabric_path, "rest_pos", sentinel_file)
    scene = out_dir / "scene.toml"
    scene.write_text(f'[scene]\nframes = [1, 2]\n[solver]\npreset = "preview"\n[cloth.c]\nfabric = "{fabric_path.name}"\n')
    result = run("bake", scene, "-o", out_dir / "out.h5")
    assert_one_line_failure(result, "cloth.c", "dataset 'rest_pos' uses external storage")
    for produced in out_dir.iterdir():  # no cache, no partial cache: nothing holds the bytes
        assert produced == sentinel_file or SENTINEL not in produced.read_bytes()


CACHE_ESCAPES = {
    "external storage": (lambda p, s: external_storage(p, f"cloth/{CLOTH}/rest", s), f"dataset 'cloth/{CLOTH}/rest' uses external storage"),
    "virtual dataset": (lambda p, s: virtual_dataset(p, f"cloth/{CLOTH}/P", s.with_suffix(".h5")), f"dataset 'cloth/{CLOTH}/P' is a virtual dataset"),
    "external link": (lambda p, s: external_link(p, f"cloth/{CLOTH}/face_vertex_indices", s.with_suffix(".h5")), f"link 'cloth/{CLOTH}/face_vertex_indices' is an external link"),
    "soft-link cycle": (lambda p, s: soft_link_cycle(p, f"/cloth/{CLOTH}"), f"soft link 'cloth/{CLOTH}/loop_a' is part of a soft-link cycle"),
}


@pytest.mark.parametrize("escape", CACHE_ESCAPES)
def test_cache_reaching_outside_itself_is_refused_before_reading(cache_path, sentinel_file, escape):
    make, message = CACHE_ESCAPES[escape]
    make(cache_path, sentinel_file)
    with pytest.raises(FormatError, match=message) as info:
        read_h5_cache(cache_path)
    assert str(cache_path) in str(info.value) and "bake it again" in str(info.value)
    assert_one_line_failure(run("inspect", cache_path), message)


def test_soft_link_into_an_external_link_is_refused(cache_path, out_dir):
    external_link(cache_path, f"cloth/{CLOTH}/face_vertex_counts", out_dir / "other.h5")
    with h5py.File(cache_path, "r+") as f:
        f["alias"] = h5py.SoftLink(f"/cloth/{CLOTH}/face_vertex_counts")
    with pytest.raises(FormatError, match="external link"):
        read_h5_cache(cache_path)


def test_plain_soft_links_and_hard_link_loops_are_walked_once(cache_path):
    with h5py.File(cache_path, "r+") as f:
        f["alias"] = h5py.SoftLink(f"/cloth/{CLOTH}/rest")
        f["cloth"]["back_to_root"] = f["/"]  # a hard link to an ancestor: a loop in the tree
    with read_h5_cache(cache_path) as cache:
        assert cache.frames == [1, 2, 3, 4]


# --------------------------------------------------------------------------- forged sizes
def test_fabric_header_claiming_terabytes_is_refused_before_allocating(fabric_path):
    replace_dataset(fabric_path, "rest_pos", shape=(2**40, 3), dtype=np.float32, chunks=(1024, 3))
    with pytest.raises(FormatError, match=r"dataset 'rest_pos' declares shape \(1099511627776, 3\)"):
        read_fabric(fabric_path)


def test_cache_header_claiming_terabytes_is_refused_before_allocating(cache_path):
    replace_dataset(cache_path, f"cloth/{CLOTH}/P", shape=(4, 2**38, 3), maxshape=(None, 2**38, 3), dtype=np.float32, chunks=(1, 1024, 3))
    result = run("inspect", cache_path)
    assert_one_line_failure(result, f"dataset 'cloth/{CLOTH}/P' declares shape", "bake it again")


# --------------------------------------------------------------------------- bad fabric data
def edit_attr(name, value):
    def edit(path):
        with h5py.File(path, "r+") as f:
            f.attrs[name] = value

    return edit


def edit_values(name, change):
    def edit(path):
        with h5py.File(path, "r") as f:
            data = f[name][()]
        data = change(data)
        replace_dataset(path, name, data=data)

    return edit


def _set(index, value):
    def change(a):
        a = a.copy()
        a[index] = value
        return a

    return change


BAD_FABRICS = {
    "NaN hang_direction": (edit_attr("hang_direction", np.array([0, np.nan, 0], np.float32)), "'hang_direction': holds NaN"),
    "7-element hang_direction": (edit_attr("hang_direction", np.zeros(7, np.float32)), "'hang_direction': has shape (7,)"),
    "float triangle indices": (edit_values("triangles", lambda a: a.astype(np.float64) + 0.7), "dataset 'triangles' has dtype float64, expected int32"),
    "2-D particle areas": (edit_values("particle_area", lambda a: a[:, None]), "dataset 'particle_area' has shape"),
    "virtual batch of 5": (edit_values("virtual_batch_offsets", lambda a: np.concatenate([[0], a[2:]]).astype(np.int32)), "'virtual_batch_offsets': batch 0 holds"),
    "virtual batch sharing a particle": (edit_values("virtual_particles", lambda a: np.concatenate([a[:1], a[:1], a[2:]])), "'virtual_batch_offsets': batch 0 uses movable particle"),
    "negative tether length": (edit_values("tether_rest_length", _set(0, -1.0)), "'tether_rest_length': holds negative lengths"),
    "negative max distance": (edit_values("particle_max_distance", _set(3, -0.5)), "'particle_max_distance': holds negative distances"),
    "negative area": (edit_values("particle_area", _set(2, -0.1)), "'particle_area': holds negative areas"),
    "string meters_per_unit": (edit_attr("meters_per_unit", "big"), "root attribute 'meters_per_unit' must be one number"),
}


@pytest.mark.parametrize("case", BAD_FABRICS)
def test_bad_fabric_data_is_refused(fabric_path, case):
    edit, message = BAD_FABRICS[case]
    edit(fabric_path)
    with pytest.raises(FormatError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_fabric(fabric_path)
    assert_one_line_failure(run("inspect", fabric_path), str(fabric_path), message, "re-cook it")


# --------------------------------------------------------------------------- bad cache data
BAD_CACHES = {
    "2-D P": (lambda p: replace_dataset(p, f"cloth/{CLOTH}/P", data=np.zeros((4, 625), np.float32)), f"dataset 'cloth/{CLOTH}/P' has shape (4, 625), expected 3 dimensions"),
    "5 of 625 points": (lambda p: replace_dataset(p, f"cloth/{CLOTH}/P", data=np.zeros((4, 5, 3), np.float32)), f"cloth '{CLOTH}' has 625 rest points but 5 points per frame"),
    "face index 10^6": (edit_values(f"cloth/{CLOTH}/face_vertex_indices", _set(7, 10**6)), "face_vertex_indices reach outside 0..624"),
    "float face indices": (edit_values(f"cloth/{CLOTH}/face_vertex_indices", lambda a: a.astype(np.float32)), "has dtype float32, expected int32"),
    "NaN fps": (edit_attr("fps", np.nan), "root attribute 'fps' must be a positive finite number, got nan"),
    "negative frame count": (edit_attr("frame_count", -3), "root attribute 'frame_count' is -3"),
    "float frame count": (edit_attr("frame_count", 2.5), "root attribute 'frame_count' must be an integer"),
    "end before start": (edit_attr("end_frame", -7), "root attribute 'end_frame' (-7) is before 'start_frame' (1)"),
    "zero meters_per_unit": (edit_attr("meters_per_unit", 0.0), "root attribute 'meters_per_unit' must be a positive finite number"),
    "cloth name with a slash": (edit_attr("cloths", json.dumps(["../x"])), "root attribute 'cloths' holds the invalid name '../x'"),
    "short velocities": (lambda p: replace_dataset(p, f"cloth/{CLOTH}/v", data=np.zeros((4, 600, 3), np.float32)), f"dataset 'cloth/{CLOTH}/v' has shape (4, 600, 3)"),
}


@pytest.mark.parametrize("case", BAD_CACHES)
def test_bad_cache_data_is_refused(cache_path, case):
    edit, message = BAD_CACHES[case]
    edit(cache_path)
    with pytest.raises(FormatError) as info:
        read_h5_cache(cache_path)
    assert message in str(info.value) and "bake it again" in str(info.value)
    line = assert_one_line_failure(run("inspect", cache_path), str(cache_path), message)
    assert "complete" not in line


def test_intact_cache_reads_complete(cache_path):
    with read_h5_cache(cache_path) as cache:
        assert cache.summary()["complete"] and cache.frames == [1, 2, 3, 4]


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("metersPerUnit", 0.0, "meters_per_unit is 0.0; give a positive unit size"),
        ("timeCodesPerSecond", float("nan"), "fps is nan"),
    ],
)
def test_bad_usd_cache_metadata_is_refused(out_dir, key, value, message):
    from pxr import Sdf

    path = write_small_cache(out_dir / "shot.usda")
    layer = Sdf.Layer.FindOrOpen(str(path))
    layer.pseudoRoot.SetInfo(key, value)
    layer.Save()
    with pytest.raises(FormatError, match="bake it again") as info:
        read_cache(path)
    assert message in str(info.value) and str(path) in str(info.value)
    assert_one_line_failure(run("inspect", path), message)


# --------------------------------------------------------------------------- meshes
def test_ply_float_face_indices_are_refused(out_dir):
    path = out_dir / "tri.ply"
    path.write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 1\nproperty list uchar float vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0.7 1.9 2.2\n"
    )
    with pytest.raises(FormatError, match="face property 'vertex_indices' is declared 'list uchar float'; vertex indices must be an integer type"):
        read_mesh(path)
    assert_one_line_failure(run("cook", path, "-o", out_dir / "tri.fabric.h5"), "tri.ply", "'vertex_indices'")
    assert not (out_dir / "tri.fabric.h5").exists()


@pytest.mark.parametrize("value", ["0", "-0.01", "inf"])
def test_usd_meters_per_unit_must_be_positive(out_dir, value):
    path = out_dir / "tri.usda"
    path.write_text(
        f'#usda 1.0\n(\n    metersPerUnit = {value}\n)\ndef Mesh "m" {{\n    point3f[] points = [(0,0,0),(1,0,0),(0,1,0)]\n'
        "    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0,1,2]\n}\n"
    )
    with pytest.raises(MeshError, match="stage metadata metersPerUnit = .*it must be a positive size"):
        read_mesh(path)


# --------------------------------------------------------------------------- scenes and presets
SCENE_HEAD = '[scene]\nframes = [1, 2]\n'


@pytest.fixture
def scene_dir(out_dir: Path, fabric_path: Path) -> Path:
    return out_dir


def load(scene_dir: Path, text: str):
    path = scene_dir / "scene.toml"
    path.write_text(text)
    return load_scene(path)


def scene_error(scene_dir: Path, text: str) -> str:
    with pytest.raises(SceneError) as info:
        load(scene_dir, text)
    message = str(info.value)
    assert "\n" not in message and "scene.toml" in message
    return message


CLOTH_TABLE = '[cloth.c]\nfabric = "cloth.fabric.h5"\n'


@pytest.mark.parametrize(
    "text, fragment",
    [
        (SCENE_HEAD + "[solver]\npreset = 5\n" + CLOTH_TABLE, "[solver] solver preset 5 is not a name"),
        ("solver = 5\n" + SCENE_HEAD + CLOTH_TABLE, "expected a solver preset name or a table, got 5"),
        (SCENE_HEAD + CLOTH_TABLE + "material = 5\n", "[cloth.c.material]: expected a material preset name"),
        (SCENE_HEAD + CLOTH_TABLE + "material = { preset = 5 }\n", "material preset 5 is not a name"),
        ('[scene]\nname = 5\n' + CLOTH_TABLE, "[scene] key 'name' must be a non-empty string, got 5"),
    ],
)
def test_wrongly_typed_scene_keys(scene_dir, text, fragment):
    assert fragment in scene_error(scene_dir, text)


def test_wrongly_typed_material_through_the_cli(scene_dir):
    path = scene_dir / "scene.toml"
    path.write_text(SCENE_HEAD + CLOTH_TABLE + "material = 5\n")
    assert_one_line_failure(run("bake", path, "-o", scene_dir / "out.h5"), "scene.toml", "material", "got 5")
    assert not (scene_dir / "out.h5").exists()


@pytest.mark.parametrize(
    "text",
    ["a = " + "[" * 50_000 + "]" * 50_000, "a = " + "{b = " * 50_000 + "1" + "}" * 50_000, "[" + ".".join(["a"] * 50_000) + "]\nx = 1\n"],
    ids=["arrays", "inline tables", "dotted headers"],
)
def test_deeply_nested_toml_is_one_line(scene_dir, text):
    path = scene_dir / "scene.toml"
    path.write_text(text)
    assert_one_line_failure(run("bake", path, "-o", scene_dir / "out.h5"), "scene.toml", "nested more than")


def test_preset_device_file_is_refused_before_reading(scene_dir):
    with pytest.raises(PresetError, match="/dev/zero: is not a regular file"):
        load_preset("solver", "/dev/zero")
    text = SCENE_HEAD + '[solver]\npreset = "/dev/zero"\n' + CLOTH_TABLE
    path = scene_dir / "scene.toml"
    path.write_text(text)
    assert_one_line_failure(run("bake", path, "-o", scene_dir / "out.h5"), "/dev/zero", "not a regular file")


def test_fifo_preset_scene_and_track_are_refused_without_blocking(scene_dir):
    # Opening a FIFO for reading blocks until a writer comes: reaching the end proves no read.
    fifo = scene_dir / "pipe.toml"
    os.mkfifo(fifo)
    with pytest.raises(PresetError, match="pipe.toml: is not a regular file"):
        load_preset("material", str(fifo))
    with pytest.raises(SceneError, match="pipe.toml: is not a regular file"):
        load_scene(fifo)
    os.mkfifo(scene_dir / "pipe.csv")
    assert "track file pipe.csv is not a regular file" in scene_error(scene_dir, track_scene(scene_dir, "pipe.csv"))


def test_preset_too_big_is_refused(scene_dir):
    big = scene_dir / "big.toml"
    big.write_bytes(b"# " + b"x" * (2 << 20) + b"\n")
    with pytest.raises(PresetError, match="big.toml: is 2,097,155 bytes, more than the 1,048,576"):
        load_preset("material", str(big))


def test_preset_error_never_quotes_the_file(scene_dir):
    foreign = scene_dir / "passwd.toml"
    foreign.write_text("root:x:0:0:root:/root:/bin/bash\ndaemon:x:1:1:daemon:/usr/sbin:/usr/sbin/nologin\n")
    with pytest.raises(PresetError) as info:
        load_preset("solver", str(foreign))
    assert "root:x" not in str(info.value) and "malformed TOML at line 1" in str(info.value)
    path = scene_dir / "scene.toml"
    path.write_text(SCENE_HEAD + f'[solver]\npreset = "{foreign.as_posix()}"\n' + CLOTH_TABLE)
    line = assert_one_line_failure(run("bake", path, "-o", scene_dir / "out.h5"), "passwd.toml", "malformed TOML")
    assert "root" not in line.replace(str(scene_dir), "")


# --------------------------------------------------------------------------- track files
def track_scene(scene_dir: Path, file_name: str) -> str:
    return SCENE_HEAD + f'[track.t]\nfile = "{file_name}"\n' + CLOTH_TABLE + 'track = "t"\n'


@pytest.mark.parametrize(
    "name, content, fragment",
    [
        ("utf16.csv", "frame,tx,ty,tz\n1,0,0,0\n".encode("utf-16"), "is not UTF-8 text"),
        ("binary.csv", bytes(range(256)) * 4, "is not UTF-8 text"),
        ("nul.csv", b"frame,tx,ty,tz\n1,0\x00,0,0\n", "holds NUL characters"),
        ("passwd.csv", b"root:x:0:0:root:/root:/bin/bash\n", "has no header row of column names"),
        ("words.csv", b"frame,tx,ty,tz\n1,0,secret,0\n", "row 2 column 3 is not a number"),
        ("ragged.csv", b"frame,tx,ty,tz\n1,0,0\n", "row 2 has 3 values, the header 4"),
    ],
)
def test_bad_csv_tracks(scene_dir, name, content, fragment):
    (scene_dir / name).write_bytes(content)
    message = scene_error(scene_dir, track_scene(scene_dir, name))
    assert fragment in message and "track 't'" in message
    assert "root:" not in message and "secret" not in message


def test_npz_track_with_strings_is_refused(scene_dir):
    np.savez(scene_dir / "strings.npz", frame=np.arange(3), translate=np.array([["a", "b", "c"]] * 3))
    message = scene_error(scene_dir, track_scene(scene_dir, "strings.npz"))
    assert "'translate' holds <U1 values; tracks need plain numbers" in message


def test_npz_track_with_pickled_objects_is_refused_without_unpickling(scene_dir, tmp_path):
    marker = tmp_path / "unpickled"
    np.savez(scene_dir / "objects.npz", frame=np.arange(3), translate=np.array([_Marker(marker)] * 3, dtype=object))
    message = scene_error(scene_dir, track_scene(scene_dir, "objects.npz"))
    assert "'translate' holds object values" in message
    assert not marker.exists()


def test_npz_track_claiming_terabytes_is_refused(scene_dir):
    path = scene_dir / "huge.npz"
    header = np.lib.format.header_data_from_array_1_0(np.zeros(3))
    header["shape"] = (2**40,)
    with zipfile.ZipFile(path, "w") as archive:
        with archive.open("frame.npy", "w") as member:
            np.lib.format.write_array_header_1_0(member, header)
            member.write(np.zeros(3).tobytes())
    message = scene_error(scene_dir, track_scene(scene_dir, "huge.npz"))
    assert "'frame' claims shape (1099511627776,)" in message


def test_npy_instead_of_npz_is_refused(scene_dir):
    np.save(scene_dir / "single.npy", np.zeros((3, 3)))
    (scene_dir / "single.npy").rename(scene_dir / "single.npz")
    assert "not a readable .npz file" in scene_error(scene_dir, track_scene(scene_dir, "single.npz"))


class _Marker:
    """Unpickling one creates a file: proof that a track file was unpickled."""

    def __init__(self, path: Path):
        self.path = str(path)

    def __reduce__(self):
        return (Path.touch, (Path(self.path),))
