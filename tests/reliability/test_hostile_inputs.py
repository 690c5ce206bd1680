"""Hostile inputs, generated: every command meets mutated meshes (every format), scenes,
fabrics and caches, and must fail safe.

For each case the command either succeeds (some mutations leave a valid file) or fails with
exit code 1 or 2 and exactly one ``Error:`` line on stderr: no traceback, no "internal
error", no file at the output path and no temporary file left in the output folder. A few
cases also run as real processes under an address-space limit and a time limit, the way a
farm runs them. Mutations come from fixed seeds, so every run tries the same cases.
"""

from __future__ import annotations

import json
import random
import resource
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.io.fabric_file import write_fabric
from clothtool.mesh.shapes import grid

SEED = 20261124
MESH_FORMATS = (".obj", ".off", ".ply", ".stl", ".gltf", ".glb", ".usda")


# --------------------------------------------------------------------------- the sources
def _grid():
    return grid(5, 5, 0.1, plane="XZ")


def _write_mesh(path: Path) -> None:
    """A 5 x 5 grid (triangles) in the format of ``path``'s suffix."""
    mesh = _grid()
    pos = mesh.vertex_pos.astype(np.float64)
    tris = mesh.face_vertex_indices.reshape(-1, 3)
    suffix = path.suffix
    if suffix == ".obj":
        lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in pos] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in tris]
        path.write_text("\n".join(lines) + "\n")
    elif suffix == ".off":
        lines = ["OFF", f"{len(pos)} {len(tris)} 0"] + [f"{x} {y} {z}" for x, y, z in pos] + [f"3 {a} {b} {c}" for a, b, c in tris]
        path.write_text("\n".join(lines) + "\n")
    elif suffix == ".ply":
        header = ["ply", "format ascii 1.0", f"element vertex {len(pos)}", "property float x", "property float y",
                  "property float z", f"element face {len(tris)}", "property list uchar int vertex_indices", "end_header"]
        body = [f"{x} {y} {z}" for x, y, z in pos] + [f"3 {a} {b} {c}" for a, b, c in tris]
        path.write_text("\n".join(header + body) + "\n")
    elif suffix == ".stl":
        lines = ["solid grid"]
        for a, b, c in tris:
            lines += ["facet normal 0 1 0", "outer loop"] + [f"vertex {x} {y} {z}" for x, y, z in pos[[a, b, c]]]
            lines += ["endloop", "endfacet"]
        path.write_text("\n".join(lines + ["endsolid grid"]) + "\n")
    elif suffix in (".gltf", ".glb"):
        import trimesh

        trimesh.Trimesh(pos, tris, process=False).export(path)
    elif suffix == ".usda":
        from pxr import Usd, UsdGeom, Vt

        stage = Usd.Stage.CreateNew(str(path))
        geom = UsdGeom.Mesh.Define(stage, "/Cloth")
        geom.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(pos.astype(np.float32)))
        geom.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(len(tris), 3, np.int32)))
        geom.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(tris.astype(np.int32).ravel()))
        stage.GetRootLayer().Save()
    else:  # pragma: no cover
        raise ValueError(suffix)


def _mutations(data: bytes, rng: random.Random) -> dict[str, bytes]:
    """Named byte-level mutations of a file's content."""
    n = len(data)
    cut = rng.randrange(1, max(n, 2))
    flipped = bytearray(data)
    for _ in range(8):
        i = rng.randrange(n)
        flipped[i] ^= 1 << rng.randrange(8)
    text = data.decode("latin-1")
    return {
        "empty": b"",
        "truncated": data[:cut],
        "half": data[: n // 2],
        "bitflips": bytes(flipped),
        "garbage": bytes(rng.randrange(256) for _ in range(300)),
        "utf16": text.encode("utf-16"),
        "control_bytes": data[:cut] + b"\r\x1b[31m\x00\x07" + data[cut:],
        "nan_numbers": text.replace("0.1", "nan", 3).replace("0.2", "1e999", 3).encode("latin-1"),
        "huge_numbers": text.replace(" 1 ", " 99999999999 ", 2).replace(" 2 ", " -7 ", 2).encode("latin-1"),
    }


# --------------------------------------------------------------------------- the checks
def _files(folder: Path) -> set[str]:
    return {p.name for p in folder.iterdir()} if folder.exists() else set()


def _assert_fails_safe(result, output: Path, before: set[str], case: str) -> None:
    """Success, or exit 1/2 with one Error line; never a traceback or a left-over file."""
    stderr = result.stderr
    assert result.exception is None or isinstance(result.exception, SystemExit), f"{case}: {result.exception!r}"
    assert "Traceback" not in stderr and "internal error" not in stderr, f"{case}: {stderr}"
    folder = output.parent
    if result.exit_code == 0:
        assert output.exists(), case
        return
    assert result.exit_code in (1, 2), f"{case}: exit {result.exit_code}: {stderr}"
    problems = [line for line in stderr.splitlines() if line.strip() and ": warning:" not in line and ": repaired:" not in line]
    assert len(problems) == 1 and problems[0].startswith("Error: "), f"{case}: {stderr!r}"
    assert not output.exists(), f"{case}: output left behind"
    # an unstable bake keeps its whole frames under the documented partial name
    left = {name for name in _files(folder) - before if ".partial." not in name}
    assert not left, f"{case}: left {sorted(left)}"


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


# --------------------------------------------------------------------------- meshes
def _mesh_cases():
    rng = random.Random(SEED)
    cases = []
    for suffix in MESH_FORMATS:
        for name in ("empty", "truncated", "half", "bitflips", "garbage", "utf16", "control_bytes", "nan_numbers", "huge_numbers"):
            cases.append((suffix, name, rng.randrange(1 << 30)))
    return cases


@pytest.mark.parametrize("suffix,mutation,seed", _mesh_cases(), ids=lambda v: str(v))
def test_cook_survives_mutated_meshes(tmp_path, suffix, mutation, seed):
    source = tmp_path / f"good{suffix}"
    _write_mesh(source)
    data = _mutations(source.read_bytes(), random.Random(seed))[mutation]
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(data)
    out = tmp_path / "out"
    out.mkdir()
    output = out / "bad.fabric.h5"
    result = _run("cook", bad, "-o", output)
    _assert_fails_safe(result, output, set(), f"{suffix}/{mutation}")


# --------------------------------------------------------------------------- scenes
SCENE = """version = 1
[scene]
fps = 24.0
frames = [1, 3]
[solver]
preset = "preview"
[output]
attributes = ["velocities", "stats"]
[track.spin]
keys = [{ time = 1, translate = [0, 0, 0] }, { time = 3, translate = [0, 0.1, 0] }]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
[collider.ball]
kind = "sphere"
center = [0.2, -0.3, 0.2]
radius = 0.1
track = "spin"
"""

# (table path, key) -> hostile values
SCENE_VALUES = [
    "nan", "inf", "-inf", "-1", "0", "1e300", "-1e300", "9223372036854775807", '"text"', "true", "[]", "[1, 2]",
    "[nan, 0, 0]", "{}", '"/dev/zero"', '"../../../../etc/passwd"', '"\\u0000\\r\\n"', "5",
]
SCENE_KEYS = [
    "scene.fps", "scene.frames", "scene.meters_per_unit", "scene.up_axis", "scene.gravity", "scene.name",
    "solver.preset", "solver.frequency", "solver.stiffness_frequency", "solver.max_speed", "solver.integrator",
    "output.attributes", "output.compression", "output.save_every",
    "cloth.sheet.fabric", "cloth.sheet.material", "cloth.sheet.scale", "cloth.sheet.translate", "cloth.sheet.rotate",
    "cloth.sheet.track", "cloth.sheet.material.damping", "cloth.sheet.material.areal_density",
    "collider.ball.radius", "collider.ball.center", "collider.ball.kind", "collider.ball.track",
    "track.spin.keys", "track.spin.interpolation",
]


@pytest.fixture(scope="module")
def sheet_fabric(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("fabric")
    path = folder / "sheet.fabric.h5"
    fabric = cook_fabric(grid(6, 6, 0.08, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 1))).fabric
    write_fabric(fabric, path)
    return path


def _scene_dir(tmp_path: Path, sheet_fabric: Path, text: str = SCENE) -> Path:
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "sheet.fabric.h5").write_bytes(sheet_fabric.read_bytes())
    (folder / "scene.toml").write_text(text)
    return folder


def _scene_cases():
    rng = random.Random(SEED + 1)
    # every key once with a random hostile value, plus a random sample of the full product
    cases = [(key, rng.choice(SCENE_VALUES)) for key in SCENE_KEYS]
    cases += rng.sample([(k, v) for k in SCENE_KEYS for v in SCENE_VALUES], 40)
    return cases


@pytest.mark.parametrize("key,value", _scene_cases(), ids=lambda v: str(v))
def test_bake_survives_hostile_settings(tmp_path, sheet_fabric, key, value):
    folder = _scene_dir(tmp_path, sheet_fabric)
    out = tmp_path / "out"
    out.mkdir()
    output = out / "shot.h5"
    result = _run("bake", folder / "scene.toml", "-o", output, "--set", f"{key}={value}", "--report", out / "r.json")
    _assert_fails_safe(result, output, set(), f"{key}={value}")


@pytest.mark.parametrize("mutation", ["empty", "truncated", "half", "bitflips", "garbage", "utf16", "control_bytes", "nan_numbers"])
def test_bake_survives_mutated_scene_files(tmp_path, sheet_fabric, mutation):
    folder = _scene_dir(tmp_path, sheet_fabric)
    scene = folder / "scene.toml"
    scene.write_bytes(_mutations(scene.read_bytes(), random.Random(SEED + 2))[mutation])
    out = tmp_path / "out"
    out.mkdir()
    output = out / "shot.usda"
    _assert_fails_safe(_run("bake", scene, "-o", output), output, set(), mutation)


def test_deeply_nested_toml_is_one_line(tmp_path, sheet_fabric):
    folder = _scene_dir(tmp_path, sheet_fabric)
    scene = folder / "scene.toml"
    scene.write_text(SCENE + "deep = " + "[" * 50_000 + "]" * 50_000 + "\n")
    out = tmp_path / "out"
    out.mkdir()
    _assert_fails_safe(_run("bake", scene, "-o", out / "x.h5"), out / "x.h5", set(), "deep")


# --------------------------------------------------------------------------- fabrics
def _set_dataset(name, make):
    def mutate(f):
        data = make(f[name][()]) if name in f else None
        del f[name]
        if data is not None:
            f.create_dataset(name, data=data)
    return mutate


FABRIC_MUTATIONS = {
    "nan_rest_pos": _set_dataset("rest_pos", lambda a: np.full_like(a, np.nan)),
    "float_indices": _set_dataset("constraint_indices", lambda a: a.astype(np.float64) + 0.5),
    "index_out_of_range": _set_dataset("constraint_indices", lambda a: a + 10_000),
    "negative_rest_length": _set_dataset("constraint_rest_length", lambda a: -np.abs(a) - 1),
    "negative_tether_length": _set_dataset("tether_rest_length", lambda a: -np.abs(a) - 1),
    "negative_area": _set_dataset("particle_area", lambda a: -np.abs(a) - 1),
    "wrong_shape": _set_dataset("rest_pos", lambda a: a.reshape(-1)),
    "missing": _set_dataset("set_offsets", lambda a: None),
    "offsets_backwards": _set_dataset("set_offsets", lambda a: a[::-1].copy()),
    "string_data": _set_dataset("particle_inv_mass", lambda a: np.array([b"x"] * len(a))),
    "format_attr": lambda f: f.attrs.__setitem__("format", "something-else"),
    "version_attr": lambda f: f.attrs.__setitem__("format_version", 99),
    "nan_hang": lambda f: f.attrs.__setitem__("hang_direction", np.array([np.nan, 0, 0], np.float32)),
    "long_hang": lambda f: f.attrs.__setitem__("hang_direction", np.zeros(7, np.float32)),
    "nan_units": lambda f: f.attrs.__setitem__("meters_per_unit", np.nan),
}


@pytest.mark.parametrize("mutation", sorted(FABRIC_MUTATIONS))
def test_inspect_and_bake_survive_corrupt_fabrics(tmp_path, sheet_fabric, mutation):
    folder = _scene_dir(tmp_path, sheet_fabric)
    with h5py.File(folder / "sheet.fabric.h5", "r+") as f:
        FABRIC_MUTATIONS[mutation](f)
    out = tmp_path / "out"
    out.mkdir()
    result = _run("inspect", folder / "sheet.fabric.h5")
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, result.stderr
    assert result.exit_code in (0, 1), result.stderr
    output = out / "shot.h5"
    _assert_fails_safe(_run("bake", folder / "scene.toml", "-o", output), output, set(), mutation)


@pytest.mark.parametrize("mutation", ["empty", "truncated", "half", "bitflips", "garbage"])
def test_bake_survives_damaged_fabric_bytes(tmp_path, sheet_fabric, mutation):
    folder = _scene_dir(tmp_path, sheet_fabric)
    path = folder / "sheet.fabric.h5"
    path.write_bytes(_mutations(path.read_bytes(), random.Random(SEED + 3))[mutation])
    out = tmp_path / "out"
    out.mkdir()
    output = out / "shot.usdc"
    _assert_fails_safe(_run("bake", folder / "scene.toml", "-o", output), output, set(), mutation)


# --------------------------------------------------------------------------- caches
@pytest.fixture(scope="module")
def caches(tmp_path_factory, sheet_fabric) -> dict[str, Path]:
    folder = _scene_dir(tmp_path_factory.mktemp("cache"), sheet_fabric)
    made = {}
    for suffix in (".h5", ".usda", ".usdc"):
        path = folder / f"shot{suffix}"
        result = _run("bake", folder / "scene.toml", "-o", path)
        assert result.exit_code == 0, result.stderr
        made[suffix] = path
    return made


@pytest.mark.parametrize("suffix", [".h5", ".usda", ".usdc"])
@pytest.mark.parametrize("mutation", ["empty", "truncated", "half", "bitflips", "garbage", "control_bytes"])
def test_inspect_survives_damaged_caches(tmp_path, caches, suffix, mutation):
    path = tmp_path / f"damaged{suffix}"
    path.write_bytes(_mutations(caches[suffix].read_bytes(), random.Random(SEED + 4))[mutation])
    result = _run("inspect", path, "--json")
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, result.stderr
    assert result.exit_code in (0, 1), result.stderr
    if result.exit_code == 1:
        assert len(result.stderr.strip().splitlines()) == 1, result.stderr
    else:
        json.loads(result.stdout)


# --------------------------------------------------------------------------- real processes
def _limited():
    """Run in the child: at most 6 GiB of address space (what a farm might allow)."""
    resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))


@pytest.mark.parametrize("case", ["frequency", "frames", "zero_file", "dev_zero_preset"])
def test_processes_fail_fast_under_limits(tmp_path, sheet_fabric, case):
    folder = _scene_dir(tmp_path, sheet_fabric)
    scene = folder / "scene.toml"
    args = {
        "frequency": ["--set", "solver.frequency=1e300", "--dry-run"],
        "frames": ["--frames", "1:9223372036854775807", "-o", "out/x.h5"],
        "zero_file": ["--set", 'cloth.sheet.fabric="zero.h5"', "-o", "out/x.h5"],
        "dev_zero_preset": ["--set", 'solver.preset="/dev/zero"', "-o", "out/x.h5"],
    }[case]
    (folder / "zero.h5").write_bytes(b"\0" * 4096)
    (folder / "out").mkdir()
    proc = subprocess.run(
        [sys.executable, "-m", "clothtool", "bake", str(scene), *args],
        cwd=folder, capture_output=True, text=True, timeout=120, preexec_fn=_limited,
    )
    assert proc.returncode in (1, 2), proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("Error: "), proc.stderr
    assert "root:" not in proc.stderr
    assert not list((folder / "out").iterdir())
