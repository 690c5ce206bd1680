"""The batch command line: cook/bake with several inputs and templates, batch files, the
manifest table, usage errors, and resume after a batch process is killed mid-way."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from click.testing import CliRunner

from clothtool.cli import main
from clothtool.io.cache import read_cache
from clothtool.io.fabric_file import read_fabric

REPO = Path(__file__).resolve().parents[2]
QUAD_GRID_OBJ = "".join(f"v {x} 0 {z}\n" for z in range(4) for x in range(4)) + "".join(
    f"f {1 + x + 4 * z} {2 + x + 4 * z} {6 + x + 4 * z} {5 + x + 4 * z}\n" for z in range(3) for x in range(3)
)


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_cook_many_meshes_from_a_glob_bad_one_fails_alone(tmp_path):
    garments = tmp_path / "garments"
    garments.mkdir()
    for name in ("shirt", "skirt"):
        (garments / f"{name}.obj").write_text(QUAD_GRID_OBJ)
    (garments / "torn.obj").write_text("v 0 0 0\nf 1 2 3\n")
    out = tmp_path / "out"
    result = run("cook", garments / "*.obj", "-o", out / "{name}.fabric.h5", "--pin-box=-1,-1,-1,0.5,1,4")
    assert result.exit_code == 1
    assert "batch: 3 jobs, 2 ok, 1 failed" in result.output
    failed = [line for line in result.output.splitlines() if line.startswith("  torn.fabric.h5: ")]
    assert len(failed) == 1 and "torn.obj" in failed[0]
    assert result.output.strip().splitlines()[-1].startswith("Error: 1 of 3 jobs failed")
    for name in ("shirt", "skirt"):
        fabric = read_fabric(out / f"{name}.fabric.h5")
        assert fabric.particle_count == 16 and (fabric.particle_inv_mass == 0).sum() == 4
    assert sorted(p.name for p in out.iterdir()) == ["manifest.json", "shirt.fabric.h5", "skirt.fabric.h5"]
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["jobs"][0]["settings"]["options"]["pin_box"] == [-1.0, -1.0, -1.0, 0.5, 1.0, 4.0]


def test_a_batch_file_cooks_then_bakes_and_a_rerun_skips_everything(tmp_path):
    (tmp_path / "garments").mkdir()
    (tmp_path / "garments" / "flag.obj").write_text(QUAD_GRID_OBJ)
    (tmp_path / "shots").mkdir()
    (tmp_path / "shots" / "wave.toml").write_text(
        'version = 1\n[scene]\nfps = 30.0\nframes = [1, 4]\n[solver]\npreset = "preview"\n'
        '[cloth.flag]\nfabric = "../out/fabrics/flag.fabric.h5"\nmaterial = "cotton"\n'
    )
    (tmp_path / "ci.toml").write_text(
        'version = 1\nmanifest = "out/manifest.json"\n'
        '[[cook]]\ninputs = ["garments/*.obj"]\noutput = "out/fabrics/{name}.fabric.h5"\noptions = { pin_box = [-1, -1, -1, 0.5, 1, 1] }\n'
        '[[bake]]\ninputs = ["shots/*.toml"]\noutput = "out/caches/{scene}/{wedge}.usdc"\n'
        'wedge = ["solver.frequency=240,480"]\n'
    )
    first = run("batch", tmp_path / "ci.toml", "--no-progress")
    assert first.exit_code == 0, first.output
    assert "batch: 3 jobs, 3 ok, 0 failed" in first.output
    with read_cache(tmp_path / "out" / "caches" / "wave" / "frequency-480.usdc") as cache:
        assert cache.frames == [1, 2, 3, 4] and cache.header.metadata["wedge:solver.frequency"] == "480"
    document = json.loads((tmp_path / "out" / "manifest.json").read_text())
    bake = next(e for e in document["jobs"] if e["kind"] == "bake")
    assert set(bake["inputs"]) == {"../shots/wave.toml", "fabrics/flag.fabric.h5"}  # the cooked fabric is an input
    again = run("batch", tmp_path / "ci.toml", "--no-progress")
    assert again.exit_code == 0 and "3 ok (3 up to date, skipped)" in again.output

    table = run("inspect", tmp_path / "out" / "manifest.json")
    assert table.exit_code == 0, table.output
    lines = table.output.splitlines()
    assert lines[0].split() == ["job", "status", "wall", "s", "cpu", "s", "max", "strain", "max", "speed", "finite"]
    assert any(line.startswith("caches/wave/frequency-240.usdc") and " ok " in line and line.endswith("yes") for line in lines)
    assert "3 jobs: 3 ok, 0 failed" in table.output


def test_batch_usage_errors_are_one_line(tmp_path, shots):
    result = run("bake", shots / "a.toml", "-o", tmp_path / "{scene}.h5", "--wedge", "solver.frequency=240,480")
    assert result.exit_code == 1 and "would both write it; add {name}, {scene} or {wedge}" in result.output
    result = run("bake", shots / "a.toml", shots / "b.toml", "-o", tmp_path / "{name}.h5", "--report", tmp_path / "r.json")
    assert result.exit_code == 2 and "--report applies to a single bake" in result.output
    result = run("bake", shots / "*.toml", "-o", tmp_path / "{shot}.h5")
    assert result.exit_code == 1 and "unknown template field '{shot}'" in result.output
    result = run("batch", tmp_path / "none.toml")
    assert result.exit_code == 1 and "batch file not found" in result.output
    (tmp_path / "typo.toml").write_text('[[bake]]\ninputs = ["x.toml"]\noutptu = "a.h5"\n')
    result = run("batch", tmp_path / "typo.toml")
    assert result.exit_code == 1 and "[[bake]] #1 key 'outptu' is unknown" in result.output
    assert all(len(r.output.strip().splitlines()) == 1 for r in [result])


def test_resume_after_the_batch_process_is_killed_redoes_only_unfinished_jobs(long_shots, tmp_path):
    command = [sys.executable, "-m", "clothtool", "bake", "a.toml", "b.toml", "-o", "../{dir}/{scene}/{wedge}.h5",
               "--wedge", "solver.frequency=240,480,960"]  # stderr is no terminal: plain progress lines
    env = {**os.environ, "PYTHONPATH": str(REPO)}

    def argv(folder):
        return [arg.replace("{dir}", folder) for arg in command]

    manifest = tmp_path / "killed" / "manifest.json"
    process = subprocess.Popen(argv("killed"), cwd=long_shots, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 180
        while not (manifest.exists() and len(json.loads(manifest.read_text())["jobs"]) >= 2):
            assert process.poll() is None and time.monotonic() < deadline, "the batch ended before it could be killed"
            time.sleep(0.02)
        process.send_signal(signal.SIGKILL)
    finally:
        process.kill()
        process.wait(timeout=30)
    finished = {e["id"] for e in json.loads(manifest.read_text())["jobs"]}
    assert 2 <= len(finished) < 6

    resumed = subprocess.run(argv("killed"), cwd=long_shots, env=env, capture_output=True, text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    assert f"6 ok ({len(finished)} up to date, skipped)" in resumed.stdout
    redone = [line.split()[2] for line in resumed.stderr.splitlines() if "] ok " in line]
    assert sorted(redone) == sorted({f"shot_{s}/frequency-{f}.h5" for s in "ab" for f in (240, 480, 960)} - finished)

    fresh = subprocess.run(argv("fresh"), cwd=long_shots, env=env, capture_output=True, text=True, timeout=300)
    assert fresh.returncode == 0, fresh.stderr
    for scene in ("shot_a", "shot_b"):
        for frequency in (240, 480, 960):
            name = f"{scene}/frequency-{frequency}.h5"
            assert (tmp_path / "killed" / name).read_bytes() == (tmp_path / "fresh" / name).read_bytes(), name
    leftovers = [p.name for p in (tmp_path / "killed").rglob(".*")]
    assert leftovers == []  # the killed job's temporary was cleaned up


def test_study_of_a_manifest_compares_each_wedge_with_its_highest_frequency(shots, tmp_path):
    import numpy as np

    out = tmp_path / "caches"
    baked = run("bake", shots / "b.toml", "-o", out / "{scene}" / "{wedge}.h5", "--wedge", "solver.frequency=240,960",
                "--no-progress")
    assert baked.exit_code == 0, baked.output
    result = run("study", out / "manifest.json", "--json")
    assert result.exit_code == 0, result.output
    (table,) = json.loads(result.output)
    assert table["reference"] == "shot_b/frequency-960.h5"
    rows = {row["id"]: row for row in table["rows"]}
    assert rows["shot_b/frequency-960.h5"]["position_rms"] == 0.0  # the reference against itself
    with read_cache(out / "shot_b" / "frequency-240.h5") as low, read_cache(out / "shot_b" / "frequency-960.h5") as high:
        first = high.points("sheet", 1).astype(np.float64)
        size = np.linalg.norm(first.max(axis=0) - first.min(axis=0))
        distances = np.concatenate([np.linalg.norm(low.points("sheet", f).astype(np.float64) - high.points("sheet", f), axis=1)
                                    for f in high.frames])
    np.testing.assert_allclose(rows["shot_b/frequency-240.h5"]["position_rms"], np.sqrt(np.mean(distances**2)) / size, rtol=1e-9)
    text = run("study", out / "manifest.json")
    assert "errors against shot_b/frequency-960.h5" in text.output and "solver.frequency=240" in text.output
    assert run("study", shots / "a.toml").exit_code == 2  # a scene still needs --sweep


def test_scheduler_without_the_dask_extra_or_with_a_bad_address_is_one_line(shots, tmp_path, monkeypatch):
    result = run("bake", shots / "a.toml", "-o", tmp_path / "{name}.h5", "--scheduler", "nowhere")
    if "not installed" not in result.output:  # the extra is installed: the address is checked
        assert result.exit_code == 1 and "give tcp://HOST:PORT of a Dask scheduler, or 'local'" in result.output
    monkeypatch.setitem(sys.modules, "distributed", None)  # as if the extra were not installed
    result = run("bake", shots / "a.toml", "-o", tmp_path / "{name}.h5", "--scheduler", "tcp://127.0.0.1:1")
    assert result.exit_code == 1
    assert 'not installed; install the extra with: python -m pip install "clothtool[dask]"' in result.output
    assert not list(tmp_path.glob("*.h5"))
