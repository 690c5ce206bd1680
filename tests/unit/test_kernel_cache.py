"""The kernel cache (clothtool._kernel_cache): where it lives, what its key depends on, that a
clone at another path reuses it, that an edit to an inlined source invalidates it, and that a
read-only install with no writable home still runs.

The cross-clone tests copy the package into two temporary "clones" and run a tiny kernel in
subprocesses (PYTHONPATH = the clone) sharing one CLOTHTOOL_CACHE_DIR; numba's per-dispatcher
cache statistics say whether the kernel was compiled (miss) or loaded (hit)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from clothtool import _kernel_cache

REPO = Path(__file__).resolve().parents[2]

RUN_KERNEL = """
import json
import numpy as np
from clothtool.solver.kernels.rows import copy_xyz
rows = np.arange(8, dtype=np.float32).reshape(2, 4)
out = np.zeros((2, 3), np.float32)
copy_xyz(rows, out)
assert out.tolist() == [[0, 1, 2], [4, 5, 6]]
stats = copy_xyz.stats
import clothtool
print(json.dumps({"package": clothtool.__file__, "hits": sum(stats.cache_hits.values()), "misses": sum(stats.cache_misses.values()),
                  "path": stats.cache_path}))
"""


def _env(pythonpath: Path, **extra: str) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("CLOTHTOOL_", "NUMBA_", "XDG_"))}
    env.update(PYTHONPATH=str(pythonpath), **extra)
    return env


def _clone(root: Path) -> Path:
    """A copy of the package (and the top-level data it reads) at ``root``, without caches."""
    ignore = shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc")
    for name in ("clothtool", "presets", "formats"):
        shutil.copytree(REPO / name, root / name, ignore=ignore)
    return root


def _run_kernel(clone: Path, cache: Path) -> dict:
    result = subprocess.run(
        [sys.executable, "-c", RUN_KERNEL], env=_env(clone, CLOTHTOOL_CACHE_DIR=str(cache)),
        capture_output=True, text=True, cwd=clone, timeout=300,
    )
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def _files(directory: Path) -> dict[str, int]:
    return {str(p.relative_to(directory)): p.stat().st_mtime_ns for p in directory.rglob("*") if p.is_file()}


def test_a_clone_at_another_path_loads_every_kernel_and_an_edit_recompiles(tmp_path):
    cache = tmp_path / "cache"
    first, second = _clone(tmp_path / "ci" / "one"), _clone(tmp_path / "elsewhere" / "two")

    compiled = _run_kernel(first, cache)
    assert Path(compiled["package"]).is_relative_to(first)
    assert (compiled["hits"], compiled["misses"]) == (0, 1)
    assert Path(compiled["path"]).is_relative_to(cache)
    assert str(first) not in compiled["path"]
    assert Path(compiled["path"]).parts[-3:] == ("clothtool", "solver", "kernels")
    files = _files(cache)

    loaded = _run_kernel(second, cache)
    assert Path(loaded["package"]).is_relative_to(second)
    assert (loaded["hits"], loaded["misses"]) == (1, 0)
    assert loaded["path"] == compiled["path"]
    assert _files(cache) == files, "the second clone wrote to the cache"

    # A comment in a module the kernel does not even import: still a new key (kernels inline
    # code and freeze globals from other modules, so every source counts).
    simd = second / "clothtool" / "_simd.py"
    simd.write_text(simd.read_text() + "\n# an edit\n")
    edited = _run_kernel(second, cache)
    assert (edited["hits"], edited["misses"]) == (0, 1)
    assert Path(edited["path"]).parents[2] != Path(compiled["path"]).parents[2]


BAKE_COUNTING_COMPILES = """
import json, runpy, sys
from numba.core import event

compiles = []


class Count(event.Listener):
    def on_start(self, data):
        compiles.append(data.data["dispatcher"].py_func.__qualname__)

    def on_end(self, data):
        pass


event.register("numba:compile", Count())
sys.argv = ["clothtool", "bake", *sys.argv[1:]]
try:
    runpy.run_module("clothtool", run_name="__main__")
except SystemExit as exit:
    assert not exit.code, exit.code
print(json.dumps(compiles))
"""


@pytest.mark.slow
def test_a_clone_at_another_path_bakes_the_walk_without_compiling(tmp_path):
    """The README's walk bake (its report measures percentiles and face penetration) in a
    second clone with the first one's cache: no kernel compiles, the frame function included
    (it calls its kernels through a table of addresses, so it is cached like they are)."""
    cache = tmp_path / "cache"
    first, second = _clone(tmp_path / "ci" / "one"), _clone(tmp_path / "elsewhere" / "two")
    compiles = []
    for clone in (first, second):
        out = tmp_path / clone.name
        out.mkdir()
        result = subprocess.run(
            [sys.executable, "-c", BAKE_COUNTING_COMPILES, str(REPO / "examples" / "skirt" / "walk.toml"),
             "--frames", "1:4", "-o", str(out / "walk.h5"), "--report", str(out / "walk.json")],
            env=_env(clone, CLOTHTOOL_CACHE_DIR=str(cache)), capture_output=True, text=True, cwd=tmp_path, timeout=600,
        )
        assert result.returncode == 0, result.stderr
        compiles.append(json.loads(result.stdout.splitlines()[-1]))
    assert "frame" in compiles[0] and len(compiles[0]) > 10
    assert compiles[1] == []


@pytest.mark.slow
def test_a_read_only_install_with_no_writable_home_bakes_with_one_warning(tmp_path):
    blocker = tmp_path / "not_a_directory"
    blocker.write_text("a regular file: nothing can be created below it, even by root\n")
    out = tmp_path / "out" / "swing.h5"
    out.parent.mkdir()
    result = subprocess.run(
        [sys.executable, "-m", "clothtool", "bake", str(REPO / "examples" / "sheet" / "swing.toml"), "--frames", "1:2",
         "-o", str(out)],
        env=_env(REPO, HOME=str(blocker / "home")), capture_output=True, text=True, cwd=tmp_path, timeout=600,
    )
    assert result.returncode == 0, result.stderr
    assert out.is_file()
    warnings = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(warnings) == 1, result.stderr
    assert warnings[0].startswith("warning: kernel cache disabled") and "CLOTHTOOL_CACHE_DIR" in warnings[0]


def test_the_cache_root_follows_the_environment(monkeypatch, tmp_path):
    for name in ("CLOTHTOOL_CACHE_DIR", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    if sys.platform.startswith("linux"):
        assert _kernel_cache.cache_root() == tmp_path / "home" / ".cache" / "clothtool" / "numba"
        monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")
        assert _kernel_cache.cache_root() == tmp_path / "home" / ".cache" / "clothtool" / "numba"
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
        assert _kernel_cache.cache_root() == tmp_path / "xdg" / "clothtool" / "numba"
    monkeypatch.setenv("CLOTHTOOL_CACHE_DIR", str(tmp_path / "explicit"))
    assert _kernel_cache.cache_root() == tmp_path / "explicit"


def test_the_key_depends_on_every_source_and_not_on_its_path(tmp_path):
    clone = _clone(tmp_path / "clone")
    script = "from clothtool import _kernel_cache as c; print(c.source_digest(), c.cache_key())"

    def digest_and_key(root: Path) -> list[str]:
        result = subprocess.run(
            [sys.executable, "-c", script], env=_env(root), capture_output=True, text=True, cwd=root, timeout=120
        )
        assert result.returncode == 0, result.stderr
        return result.stdout.split()

    here = [_kernel_cache.source_digest(), _kernel_cache.cache_key()]
    assert digest_and_key(clone) == here
    report = clone / "clothtool" / "report.py"
    report.write_text(report.read_text() + "\n")
    edited = digest_and_key(clone)
    assert edited[0] != here[0] and edited[1] != here[1]


def test_kernels_carry_the_package_cache():
    from clothtool.solver.kernels.fabric import solve_phases_parallel
    from clothtool.solver.kernels.rows import copy_xyz

    for dispatcher in (copy_xyz, solve_phases_parallel):
        assert isinstance(dispatcher._cache, _kernel_cache.PackageFunctionCache)
        path = Path(dispatcher._cache.cache_path)
        assert path.parts[-3:] == ("clothtool", "solver", "kernels")
        assert path.parents[2].name == _kernel_cache.cache_key()


def test_warmup_clear_removes_the_cache(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from clothtool.cli import main

    cache = tmp_path / "cache"
    (cache / "somekey" / "clothtool").mkdir(parents=True)
    monkeypatch.setenv("CLOTHTOOL_CACHE_DIR", str(cache))
    result = CliRunner().invoke(main, ["warmup", "--clear"])
    assert result.exit_code == 0, result.output
    assert not cache.exists()


def test_warmup_covers_every_integrator_precision_and_threading():
    from clothtool.warmup import variants

    labels = {v.label for v in variants()}
    for integrator in ("pbd nvcloth", "pbd xpbd", "implicit", "explicit"):
        for precision in ("float32", "float64"):
            for threads in ("serial", "parallel"):
                assert f"{integrator} {precision} {threads}" in labels
    parallel = [v for v in variants() if " parallel" in v.label]
    assert parallel and all("solver.parallel_threshold=1" in v.overrides for v in parallel)
    # the particle collision kernel is compiled per combination of collider kinds
    for precision in ("float32", "float64"):
        for threads in ("serial", "parallel"):
            combos = {
                (v.meshes, v.convexes, "solver.continuous_collision=true" in v.overrides or "continuous" not in str(v.overrides))
                for v in variants() if v.label.startswith("pbd") and f"{precision} {threads}" in v.label
            }
            assert len(combos) == 8, combos


WARM_THEN_BAKE = """
import sys
from clothtool.warmup import warm_up_kernels
from clothtool.bake import make_solvers
from clothtool.profile import StageProfiler
from clothtool.loading import load_scene
from clothtool.solver.measure import ClothMeter

# the position-based float64 (the default precision) serial variants: the README walk bake's configuration
warm_up_kernels(only=lambda v: v.label.startswith("pbd") and "float64 serial" in v.label)
print("warmed", flush=True)
sys.stdin.readline()  # the test lists the cache's files now
scene = load_scene(sys.argv[1])
for solver in make_solvers(scene, StageProfiler()):
    solver.warm_up()
    ClothMeter(solver).warm_up(True)
"""


@pytest.mark.slow
def test_warmup_leaves_nothing_for_the_readme_walk_to_compile(tmp_path):
    cache = tmp_path / "cache"
    child = subprocess.Popen(
        [sys.executable, "-c", WARM_THEN_BAKE, str(REPO / "examples" / "skirt" / "walk.toml")],
        env=_env(REPO, CLOTHTOOL_CACHE_DIR=str(cache)), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, cwd=tmp_path,
    )
    assert child.stdout.readline().strip() == "warmed", child.stderr.read()
    files = _files(cache)
    assert files
    _, stderr = child.communicate("\n", timeout=900)
    assert child.returncode == 0, stderr
    assert _files(cache) == files, "the walk compiled kernels the warm-up did not"
