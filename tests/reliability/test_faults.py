"""Faults a bake must survive: nothing lost, nothing leaked.

A full disk (a real tmpfs where this machine lets us mount one, an injected ENOSPC always),
SIGTERM and SIGINT in the middle of a bake, ``kill -9`` followed by a re-run, and a read-only
output directory. In every case: exit code 1, one ``Error:`` line on stderr, nothing under
the final name, no temporary file left, and a partial file only when it holds whole frames
(checked frame by frame against the same bake kept in memory).
"""

from __future__ import annotations

import errno
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from clothtool.bake import BakeOptions, bake
from clothtool.cli import main
from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.errors import ClothtoolError
from clothtool.io import atomic
from clothtool.io.cache import partial_path, read_cache
from clothtool.io.fabric_file import write_fabric
from clothtool.io.memory import MemoryCacheWriter
from clothtool.loading import load_scene
from clothtool.mesh.shapes import grid
from tests.conftest import REPO

CLOTH = "sheet"
SCENE = """
version = 1
[scene]
fps = 30.0
frames = [1, {end}]
[solver]
preset = "preview"
[output]
attributes = ["velocities"]
[cloth.sheet]
fabric = "sheet.fabric.h5"
material = "cotton"
"""
LONG = 100_000  # frames of a bake that runs until a signal stops it


def make_scene(folder: Path, end: int) -> Path:
    """A 16x16 sheet pinned along one edge (it swings down), frames 1..end."""
    folder.mkdir(parents=True, exist_ok=True)
    fabric = cook_fabric(grid(16, 16, 0.04, plane="XZ"), CookOptions(pin_box=(-1, -1, -1, 0.01, 1, 1))).fabric
    write_fabric(fabric, folder / "sheet.fabric.h5")
    scene = folder / f"scene{end}.toml"
    scene.write_text(SCENE.format(end=end))
    return scene


@pytest.fixture(scope="module")
def scene_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("scene")
    make_scene(folder, 200)
    make_scene(folder, LONG)
    return folder


def write_grid_obj(path: Path, size: int) -> Path:
    """A size x size grid of triangles as an OBJ file."""
    mesh = grid(size, size, 0.02, plane="XZ")
    triangles = mesh.face_vertex_indices.reshape(-1, 3) + 1
    vertices = "".join(f"v {x} {y} {z}\n" for x, y, z in mesh.vertex_pos)
    path.write_text(vertices + "".join(f"f {a} {b} {c}\n" for a, b, c in triangles))
    return path


def reference_frames(scene: Path, last: int) -> dict[int, tuple[np.ndarray, ...]]:
    """The bake's frames 1..last, kept in memory (a bake is deterministic)."""
    writer = MemoryCacheWriter()
    bake(load_scene(scene, frames=(1, last)), writer)
    return writer.frames


def assert_whole_frames(partial: Path, scene: Path, frames: int, complete: bool = False) -> None:
    """``partial`` is readable, holds frames 1..frames, and each is the frame the bake made."""
    with read_cache(partial) as cache:
        assert cache.frames == list(range(1, frames + 1))
        assert cache.summary()["complete"] == complete
        expected = reference_frames(scene, frames)
        for frame in cache.frames:
            np.testing.assert_array_equal(cache.points(CLOTH, frame), expected[frame][0].astype(np.float32), err_msg=f"frame {frame}")


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


def clothtool(*args, **popen) -> subprocess.Popen:
    """``python -m clothtool ARGS`` in a subprocess running this checkout."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    return subprocess.Popen(
        [sys.executable, "-m", "clothtool", *map(str, args)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env, **popen,
    )


def run_clothtool(*args, timeout: float = 120) -> subprocess.CompletedProcess:
    process = clothtool(*args)
    stdout, stderr = process.communicate(timeout=timeout)
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


def one_error_line(stderr: str) -> str:
    """The single ``Error:`` line a failed command prints (no traceback, nothing else)."""
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("Error: "), stderr[-3000:]
    assert "Traceback" not in stderr
    return lines[0]


# ---------------------------------------------------------------------------------------------
# A real full disk: a small tmpfs, where mounting one is allowed.


@pytest.fixture
def small_tmpfs(tmp_path):
    """Mount tmpfs filesystems under tmp_path: ``mount(size, read_only=False) -> Path``.
    Skips the test where this machine does not let us mount (not root, no mount, a container)."""
    mounted = []

    def mount(size: str, read_only: bool = False) -> Path:
        if os.name != "posix" or os.geteuid() != 0:
            pytest.skip("mounting a tmpfs needs root")
        point = tmp_path / f"tmpfs{len(mounted)}"
        point.mkdir()
        options = f"size={size},mode=0777" + (",ro" if read_only else "")
        try:
            done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(point)], capture_output=True, text=True)
        except FileNotFoundError:
            pytest.skip("no mount command")
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
        mounted.append(point)
        return point

    yield mount
    for point in mounted:
        if subprocess.run(["umount", str(point)], capture_output=True).returncode != 0:
            subprocess.run(["umount", "-l", str(point)], capture_output=True)


@pytest.mark.parametrize(
    "name, options, keeps_frames",
    [("x.h5", (), True), ("x.h5", ("--compression", "none"), True), ("x.usdc", (), False), ("x.usda", (), False)],
    ids=["h5-gzip", "h5-uncompressed", "usdc", "usda"],
)
def test_disk_full_during_a_bake(scene_dir, small_tmpfs, name, options, keeps_frames):
    disk = small_tmpfs("256k")  # the 200 frames need about 1.2 MB
    # --force: past the up-front free-space check, into a real disk-full mid-bake
    done = run_clothtool("bake", scene_dir / "scene200.toml", "-o", disk / name, "--force", *options)
    assert done.returncode == 1, done.stderr[-3000:]
    line = one_error_line(done.stderr)
    assert re.match(rf"Error: {re.escape(str(disk / name))}: disk full while (writing frame \d+|saving the layer) "
                    r"\(No space left on device\); free space or choose another directory", line), line
    partial = partial_path(disk / name)
    kept = re.search(r"; kept (\d+) frames in (.*)$", line)
    if keeps_frames:  # HDF5 keeps the frames flushed before the disk filled
        assert kept and Path(kept[2]) == partial, line
        assert leftovers(disk) == [partial.name]
        assert_whole_frames(partial, scene_dir / "scene200.toml", int(kept[1]))
    else:  # a failed USD save leaves a file no reader can open: nothing is kept
        assert not kept, line
        assert leftovers(disk) == []


def test_disk_full_during_cook_and_report(scene_dir, small_tmpfs, tmp_path):
    disk = small_tmpfs("64k")
    mesh = write_grid_obj(tmp_path / "big.obj", 64)
    done = run_clothtool("cook", mesh, "-o", disk / "big.fabric.h5")
    assert done.returncode == 1
    assert one_error_line(done.stderr) == (
        f"Error: {disk / 'big.fabric.h5'}: disk full while writing the fabric (No space left on device); "
        "free space or choose another directory"
    )
    assert leftovers(disk) == []
    (disk / "filler").write_bytes(b"\0" * (64 * 1024 - 4096))  # leaves one page: not enough for the report
    done = run_clothtool("bake", scene_dir / "scene200.toml", "--frames", "1:3", "-o", "null", "--report", disk / "r.html")
    assert done.returncode == 1
    assert "disk full while writing the report" in one_error_line(done.stderr)
    assert leftovers(disk) == ["filler"]


# ---------------------------------------------------------------------------------------------
# An injected ENOSPC in the writers: runs everywhere.


class SmallDisk:
    """The room left on a disk that every h5py write draws from. A write that does not fit
    fails, and every later flush too, with the errors h5py gives on a full disk."""

    def __init__(self, room: int, flushes: int | None = None):
        self.room = room
        self.flushes = flushes  # flushes that succeed before one fails (None: as room allows)

    def take(self, nbytes: int) -> None:
        if nbytes > self.room:
            self.room = 0
            raise OSError(errno.ENOSPC, "Can't synchronously write data (file write failed: "
                                        "errno = 28, error message = 'No space left on device')")
        self.room -= nbytes

    def check_flush(self) -> None:
        if self.flushes is not None:
            self.flushes -= 1
            if self.flushes < 0:
                self.room = 0
        if self.room == 0:
            raise RuntimeError("Unable to synchronously flush file (file write failed: "
                               "errno = 28, error message = 'No space left on device')")


@pytest.fixture
def small_disk(monkeypatch):
    """``small_disk(room, flushes=None) -> SmallDisk``: from then on h5py's dataset writes, dataset creation
    with data, the HDF5 cache's pre-compressed chunks, and file flushes draw on ``room`` bytes (the
    writers' own calls, unchanged). Where a tmpfs can be mounted, the tests above fill a real disk."""
    import h5py

    from clothtool.io import h5chunks

    def give(room: int, flushes: int | None = None) -> SmallDisk:
        disk = SmallDisk(room, flushes)
        setitem, create_dataset, flush = h5py.Dataset.__setitem__, h5py.Group.create_dataset, h5py.File.flush

        def write(dataset, key, value):
            disk.take(np.asarray(value).nbytes)
            setitem(dataset, key, value)

        def create(group, name, shape=None, dtype=None, data=None, **options):
            disk.take(0 if data is None else np.asarray(data).nbytes)
            return create_dataset(group, name, shape, dtype, data, **options)

        def flush_file(file):
            disk.check_flush()
            flush(file)

        def chunk(chunks, k, data, write=h5chunks.FrameChunks.write):
            disk.take(memoryview(data).nbytes)
            write(chunks, k, data)

        monkeypatch.setattr(h5py.Dataset, "__setitem__", write)
        monkeypatch.setattr(h5py.Group, "create_dataset", create)
        monkeypatch.setattr(h5py.File, "flush", flush_file)
        monkeypatch.setattr(h5chunks.FrameChunks, "write", chunk)
        return disk

    return give


@pytest.mark.parametrize("room, flushes", [(150_000, None), (10**9, 20)], ids=["a-write-fails", "a-flush-fails"])
def test_injected_enospc_in_the_hdf5_cache_writer(scene_dir, out_dir, small_disk, room, flushes):
    small_disk(room, flushes)
    scene = scene_dir / "scene200.toml"
    with pytest.raises(ClothtoolError, match=r"x\.h5: disk full while writing frame (\d+) \(No space left on device\)") as failure:
        bake(load_scene(scene), out_dir / "x.h5")
    frame = int(re.search(r"frame (\d+)", str(failure.value))[1])
    assert failure.value.kept == (out_dir / "x.partial.h5", frame - 1) and failure.value.frame == frame
    assert leftovers(out_dir) == ["x.partial.h5"]
    assert_whole_frames(out_dir / "x.partial.h5", scene, frame - 1)


def test_injected_enospc_while_writing_the_hdf5_header_keeps_nothing(scene_dir, out_dir, small_disk):
    small_disk(2_000)
    with pytest.raises(ClothtoolError, match=r"disk full while writing the header"):
        bake(load_scene(scene_dir / "scene200.toml"), out_dir / "x.h5")
    assert leftovers(out_dir) == []


def test_a_disk_full_at_the_final_flush_commits_nothing(scene_dir, out_dir, small_disk):
    small_disk(10**9, flushes=1 + 6)  # the header's flush and each frame's succeed; the closing one fails
    scene = scene_dir / "scene200.toml"
    with pytest.raises(ClothtoolError, match=r"x\.h5: disk full while closing the file") as failure:
        bake(load_scene(scene, frames=(1, 6)), out_dir / "x.h5")
    # Every frame was flushed before the disk filled: they read back, so they are kept.
    assert failure.value.kept == (out_dir / "x.partial.h5", 6)
    assert leftovers(out_dir) == ["x.partial.h5"]
    assert_whole_frames(out_dir / "x.partial.h5", scene, 6, complete=True)


def test_a_disk_full_on_the_last_frame_names_it_and_keeps_the_frames_before(scene_dir, out_dir, small_disk):
    """The disk fills after frame 5 is flushed: writing the last frame fails, naming it, and
    the five frames flushed before it are kept."""
    disk = small_disk(10**9)

    def fill_the_disk_before_the_last_frame(done: int, total: int) -> None:
        if done == total - 1:
            disk.room = 0

    options = BakeOptions(progress=fill_the_disk_before_the_last_frame)
    scene = scene_dir / "scene200.toml"
    with pytest.raises(ClothtoolError, match=r"x\.h5: disk full while writing frame 6 \(No space left on device\)") as failure:
        bake(load_scene(scene, frames=(1, 6)), out_dir / "x.h5", options)
    assert failure.value.kept == (out_dir / "x.partial.h5", 5) and failure.value.frame == 6
    assert leftovers(out_dir) == ["x.partial.h5"]
    assert_whole_frames(out_dir / "x.partial.h5", scene, 5)


def test_a_failed_usd_save_is_never_retried_and_nothing_is_kept(scene_dir, out_dir, monkeypatch):
    """Saving a layer again after a failed save crashed USD; the crate file is unreadable after one."""
    from pxr import Sdf

    save = Sdf.Layer.Save
    calls = []

    def failing_third_save(layer, force=False):
        calls.append(layer.identifier)
        return save(layer, force) if len(calls) < 3 else False

    monkeypatch.setattr(Sdf.Layer, "Save", failing_third_save)
    with pytest.raises(ClothtoolError, match=r"x\.usdc: cannot write while writing frame 30 \(USD reported a failed save\)"):
        bake(load_scene(scene_dir / "scene200.toml"), out_dir / "x.usdc")  # saved every 10 frames
    assert len(calls) == 3
    assert leftovers(out_dir) == []


def test_injected_enospc_in_the_fabric_writer_and_cook(out_dir, small_disk, tmp_path):
    fabric = cook_fabric(grid(32, 32, 0.02, plane="XZ"), CookOptions()).fabric
    small_disk(20_000)
    with pytest.raises(ClothtoolError, match=r"sheet\.fabric\.h5: disk full while writing the fabric"):
        write_fabric(fabric, out_dir / "sheet.fabric.h5")
    mesh = write_grid_obj(tmp_path / "sheet.obj", 8)
    result = CliRunner().invoke(main, ["cook", str(mesh), "-o", str(out_dir / "cooked.fabric.h5")])
    assert result.exit_code == 1
    assert "disk full while writing the fabric" in result.output and "Traceback" not in result.output
    assert leftovers(out_dir) == []


def test_injected_enospc_while_writing_the_report(scene_dir, out_dir, monkeypatch):
    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_text", full)
    result = CliRunner().invoke(main, ["bake", str(scene_dir / "scene200.toml"), "--frames", "1:3", "-o", "null",
                                       "--report", str(out_dir / "r.json")])
    assert result.exit_code == 1
    assert f"Error: {out_dir / 'r.json'}: disk full while writing the report (No space left on device)" in result.output
    assert leftovers(out_dir) == []


# ---------------------------------------------------------------------------------------------
# Signals: SIGTERM (timeout, schedulers, systemd) and SIGINT (Ctrl-C) mid-bake, kill -9.


def start_long_bake(scene_dir: Path, output: Path) -> tuple[subprocess.Popen, Path]:
    """Start a bake that would run for minutes; return it once its temporary file holds frames."""
    process = clothtool("bake", scene_dir / f"scene{LONG}.toml", "-o", output)
    deadline = time.monotonic() + 90  # a first run compiles the kernels
    while time.monotonic() < deadline and process.poll() is None:
        temporaries = [p for p in output.parent.iterdir() if p.name.startswith(f".{output.name}.clothtool-tmp.")]
        if temporaries and temporaries[0].stat().st_size > 60_000:  # several frames of 6 kB
            return process, temporaries[0]
        time.sleep(0.05)
    process.kill()
    pytest.fail(f"the bake never got going: {process.communicate()[1][-2000:]}")


@pytest.mark.parametrize("signal_name", ["SIGTERM", "SIGINT"])
@pytest.mark.parametrize("name", ["x.h5", "x.usdc"])
def test_a_signal_mid_bake_keeps_whole_frames(scene_dir, out_dir, signal_name, name):
    process, temporary = start_long_bake(scene_dir, out_dir / name)
    assert f".{process.pid}." in temporary.name  # named after the process writing it
    process.send_signal(getattr(signal, signal_name))
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 1, stderr[-3000:]
    line = one_error_line(stderr)
    match = re.fullmatch(rf"Error: interrupted \({signal_name}\) at frame (\d+); kept (\d+) frames in (.*)", line)
    assert match, line
    frame, kept, partial = int(match[1]), int(match[2]), Path(match[3])
    assert frame == kept + 1 and partial == partial_path(out_dir / name)
    assert leftovers(out_dir) == [partial.name]  # nothing under the final name, no temporary file
    assert_whole_frames(partial, scene_dir / f"scene{LONG}.toml", kept)


def test_an_interrupted_cook_leaves_nothing(out_dir, tmp_path, monkeypatch):
    from clothtool.cli.common import Interrupted
    from clothtool.io import fabric_file

    write_arrays = fabric_file._write_fabric_file

    def terminated_half_way(fabric, f):
        write_arrays(fabric, f)
        raise Interrupted("SIGTERM")  # as the signal handler raises it

    monkeypatch.setattr(fabric_file, "_write_fabric_file", terminated_half_way)
    result = CliRunner().invoke(main, ["cook", str(write_grid_obj(tmp_path / "sheet.obj", 8)), "-o", str(out_dir / "s.fabric.h5")])
    assert result.exit_code == 1
    assert result.output == "Error: interrupted (SIGTERM); no output written\n"
    assert leftovers(out_dir) == []


def test_the_next_run_removes_what_kill_9_left(scene_dir, out_dir):
    process, temporary = start_long_bake(scene_dir, out_dir / "x.h5")
    process.kill()
    process.communicate(timeout=30)
    assert temporary.exists()  # a killed process cannot clean up
    done = run_clothtool("bake", scene_dir / f"scene{LONG}.toml", "--frames", "1:3", "-o", out_dir / "x.h5")
    assert done.returncode == 0, done.stderr[-3000:]
    assert leftovers(out_dir) == ["x.h5"]


def test_only_temporaries_of_gone_processes_are_removed(out_dir):
    ours = atomic.temporary_sibling(out_dir / "a.h5")
    pid, start, space = re.search(r"clothtool-tmp\.(\d+)\.(\d+)\.([0-9a-f]{8})$", ours.name).groups()
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    names = {
        ours.name: "kept",  # this process is writing it
        f".b.h5.clothtool-tmp.{gone.pid}.{start}.{space}": "removed",  # its process has exited
        f".c.usdc.clothtool-tmp.{pid}.{int(start) + 1}.{space}.usdc": "removed",  # the pid now belongs to someone else
        f".d.h5.clothtool-tmp.{gone.pid}.{start}.{'0' * 8 if space != '0' * 8 else '1' * 8}": "kept",  # another boot or host
        f".e.h5.tmp-{gone.pid}": "removed",  # the older naming, its pid unused
        f".f.usda.tmp-{pid}.usda": "kept",  # the older naming, its pid in use
        f".g.h5.someone-else.{gone.pid}": "kept",  # not clothtool's
    }
    for name in names:
        (out_dir / name).write_bytes(b"x")
    removed = atomic.remove_stale_temporaries(out_dir)
    assert sorted(p.name for p in removed) == sorted(n for n, fate in names.items() if fate == "removed")
    assert leftovers(out_dir) == sorted(n for n, fate in names.items() if fate == "kept")


# ---------------------------------------------------------------------------------------------
# A read-only output directory.


@pytest.fixture
def read_only_dir(tmp_path, small_tmpfs):
    """A directory this process cannot write: chmod where it binds, else a read-only tmpfs."""
    if os.geteuid() != 0:
        folder = tmp_path / "read-only"
        folder.mkdir()
        folder.chmod(0o555)
        yield folder
        folder.chmod(0o755)
    else:  # root writes through chmod
        yield small_tmpfs("1m", read_only=True)


def test_read_only_output_directory(scene_dir, read_only_dir, tmp_path):
    runner = CliRunner()
    mesh = tmp_path / "quad.obj"
    mesh.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    commands = [
        ["bake", scene_dir / "scene200.toml", "--frames", "1:3", "-o", read_only_dir / "x.h5"],
        ["bake", scene_dir / "scene200.toml", "--frames", "1:3", "-o", read_only_dir / "x.usdc"],
        ["bake", scene_dir / "scene200.toml", "--frames", "1:3", "-o", "null", "--report", read_only_dir / "r.json"],
        ["cook", mesh, "-o", read_only_dir / "quad.fabric.h5"],
    ]
    for command in commands:
        result = runner.invoke(main, [str(a) for a in command])
        assert result.exit_code == 1, result.output
        lines = result.output.strip().splitlines()
        assert lines == [f"Error: {command[-1]}: output directory '{read_only_dir}' is not writable; "
                         "choose another directory or fix its permissions"]
    assert leftovers(read_only_dir) == []
