"""bake_many: good and bad jobs, wedge metadata, the manifest, resume, process workers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from clothtool.batch import bake_many, expand_wedges, local_executor, make_jobs
from clothtool.batch.inputs import file_sha256
from clothtool.io.cache import read_cache


def _jobs(shots: Path, out: Path, names=("a.toml", "broken.toml", "missing.toml", "b.toml"), wedge=()):
    return make_jobs("bake", [shots / n for n in names], "{name}/{wedge}.h5", wedges=expand_wedges(list(wedge)), base=out)


def _strip_timing(manifest: Path) -> dict:
    document = json.loads(manifest.read_text())
    for entry in document["jobs"]:
        entry.pop("timing")
    document["summary"].pop("wall_s"), document["summary"].pop("cpu_s")
    return document


def test_bad_jobs_fail_alone_with_one_line_each(shots, tmp_path):
    out = tmp_path / "out"
    result = bake_many(_jobs(shots, out), manifest=out / "manifest.json")
    status = {e["id"]: e["status"] for e in result.entries}
    assert status == {"a/base.h5": "ok", "broken/base.h5": "failed", "missing/base.h5": "failed", "b/base.h5": "ok"}
    errors = {e["id"]: e["error"] for e in result.failed}
    assert "unknown top-level key 'bogus'" in errors["broken/base.h5"] and "broken.toml" in errors["broken/base.h5"]
    assert "scene file not found" in errors["missing/base.h5"]
    assert all("\n" not in line for line in errors.values())
    assert not result.ok and result.skipped == []
    assert (out / "a" / "base.h5").is_file() and (out / "b" / "base.h5").is_file()
    assert not (out / "broken").exists() or not any((out / "broken").iterdir())  # no output, no temporaries
    with read_cache(out / "b" / "base.h5") as cache:
        assert cache.frames == [1, 2, 3, 4, 5]


def test_wedges_write_one_cache_each_with_their_settings_in_the_metadata(shots, tmp_path):
    out = tmp_path / "out"
    jobs = make_jobs("bake", [shots / "a.toml"], "{scene}/{wedge}.usdc",
                     wedges=expand_wedges(["solver.frequency=240,480"]), base=out)
    result = bake_many(jobs, manifest=out / "manifest.json")
    assert result.ok, result.failed
    for frequency in (240, 480):
        path = out / "shot_a" / f"frequency-{frequency}.usdc"
        with read_cache(path) as cache:
            assert cache.header.metadata["wedge"] == f"frequency-{frequency}"
            assert cache.header.metadata["wedge:solver.frequency"] == str(frequency)
            assert cache.header.metadata["scene"] == "shot_a"
    entries = {e["id"]: e for e in result.entries}
    entry = entries["shot_a/frequency-480.usdc"]
    assert entry["settings"]["wedge"] == {"solver.frequency": 480}
    assert entry["resolved"]["solver"]["frequency"] == 480  # the wedge reached the solver
    assert entry["stats"]["finite"] and 0 < entry["stats"]["max_strain"] < 1
    assert set(entry["inputs"]) == {"../shots/a.toml", "../shots/sheet.fabric.h5"}
    assert entry["outputs"] == {"shot_a/frequency-480.usdc": file_sha256(out / "shot_a" / "frequency-480.usdc")}


def test_manifest_is_deterministic_and_has_no_absolute_paths(shots, tmp_path):
    documents = []
    for run in ("one", "two"):
        out = tmp_path / run
        bake_many(_jobs(shots, out, names=("a.toml", "broken.toml")), manifest=out / "manifest.json")
        text = (out / "manifest.json").read_text()
        assert str(tmp_path) not in text
        documents.append(_strip_timing(out / "manifest.json"))
    assert documents[0] == documents[1]
    assert [e["id"] for e in documents[0]["jobs"]] == ["a/base.h5", "broken/base.h5"]
    assert documents[0]["summary"] == {"jobs": 2, "ok": 1, "failed": 1}


class Interrupted(Exception):
    pass


def test_resume_after_an_interrupted_batch_redoes_only_unfinished_jobs(shots, tmp_path):
    out, fresh = tmp_path / "out", tmp_path / "fresh"
    jobs = _jobs(shots, out, names=("a.toml", "b.toml"), wedge=["solver.frequency=240,480"])
    manifest = out / "manifest.json"

    def stop_after_two(entry, skipped):
        if len(json.loads(manifest.read_text())["jobs"]) == 2:
            raise Interrupted  # as if the batch were killed after its second job

    with pytest.raises(Interrupted):
        bake_many(jobs, manifest=manifest, on_result=stop_after_two)
    done = {e["id"] for e in json.loads(manifest.read_text())["jobs"]}
    assert len(done) == 2
    seen = []
    result = bake_many(jobs, manifest=manifest, on_result=lambda e, skipped: seen.append((e["id"], skipped)))
    assert result.ok and sorted(result.skipped) == sorted(done)
    assert sorted(i for i, skipped in seen if not skipped) == sorted({e["id"] for e in result.entries} - done)
    bake_many(_jobs(shots, fresh, names=("a.toml", "b.toml"), wedge=["solver.frequency=240,480"]))
    for entry in result.entries:
        assert (out / entry["id"]).read_bytes() == (fresh / entry["id"]).read_bytes()

    # a changed input or setting, or a damaged output, is redone; the rest is skipped
    (shots / "b.toml").write_text((shots / "b.toml").read_text().replace("frames = [1, 5]", "frames = [1, 3]"))
    (out / "a" / "frequency-240.h5").write_bytes(b"damaged")
    again = bake_many(jobs, manifest=manifest)
    assert sorted(again.skipped) == ["a/frequency-480.h5"]
    assert (out / "a" / "frequency-240.h5").read_bytes() == (fresh / "a" / "frequency-240.h5").read_bytes()


def test_two_worker_processes_give_the_same_bytes_as_one_process(shots, tmp_path):
    jobs = {run: _jobs(shots, tmp_path / run, names=("a.toml", "broken.toml", "b.toml"), wedge=["solver.frequency=240,480"])
            for run in ("serial", "pool")}
    serial = bake_many(jobs["serial"], manifest=tmp_path / "serial" / "manifest.json")
    with local_executor(2) as executor:
        pooled = bake_many(jobs["pool"], executor=executor, manifest=tmp_path / "pool" / "manifest.json")
    assert [e["status"] for e in serial.entries] == [e["status"] for e in pooled.entries] == ["ok"] * 2 + ["failed"] * 2 + ["ok"] * 2
    for entry in serial.entries:
        if entry["status"] == "ok":
            assert (tmp_path / "serial" / entry["id"]).read_bytes() == (tmp_path / "pool" / entry["id"]).read_bytes()
    assert _strip_timing(tmp_path / "serial" / "manifest.json") == _strip_timing(tmp_path / "pool" / "manifest.json")
