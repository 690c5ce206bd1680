"""A real Dask cluster on 127.0.0.1: a scheduler and two single-threaded workers started as
`dask scheduler` / `dask worker` processes; one worker is killed mid-batch and every output
must still be complete and identical to a local run. Skipped without the dask extra."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

distributed = pytest.importorskip("distributed")

from clothtool.batch import bake_many, expand_wedges, make_jobs  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TIMEOUT = 240


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.fixture
def cluster(tmp_path):
    """(scheduler address, {worker name: process}); every process is killed at the end."""
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    logs = tmp_path / "dask-logs"
    logs.mkdir()
    processes = {}

    def start(name, args):
        with open(logs / f"{name}.log", "wb") as log:
            processes[name] = subprocess.Popen([sys.executable, "-m", "dask", *args], env=env, stdout=log,
                                               stderr=subprocess.STDOUT, start_new_session=True, cwd=tmp_path)

    try:
        start("scheduler", ["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"])
        for name in ("w1", "w2"):
            start(name, ["worker", address, "--name", name, "--nthreads", "1", "--nworkers", "1", "--host", "127.0.0.1",
                         "--no-dashboard", "--preload-nanny", "clothtool.batch.dask_nanny", "--death-timeout", "60",
                         "--local-directory", str(tmp_path / f"dask-{name}")])
        yield address, processes
    finally:
        for process in processes.values():
            if process.poll() is None:
                os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=30)


def test_a_batch_survives_a_worker_killed_mid_job(cluster, long_shots, tmp_path):
    address, processes = cluster
    shots = long_shots

    with distributed.Client(address, timeout=60) as client:
        client.wait_for_workers(2, timeout=120)
        environ = client.run(lambda: (os.environ.get("MALLOC_TRIM_THRESHOLD_"), os.environ.get("NUMBA_NUM_THREADS")))
        assert set(environ.values()) == {(None, "1")}  # the nanny preload dropped Dask's malloc setting
        names = {info["name"]: addr for addr, info in client.scheduler_info()["workers"].items()}

        command = [sys.executable, "-m", "clothtool", "bake", str(shots / "a.toml"), str(shots / "b.toml"),
                   "-o", str(tmp_path / "farm" / "{scene}" / "{wedge}.h5"), "--wedge", "solver.frequency=240,480,960",
                   "--scheduler", address, "--no-progress"]
        env = {**os.environ, "PYTHONPATH": str(REPO)}
        batch = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path)
        try:
            deadline = time.monotonic() + TIMEOUT
            while not client.processing().get(names["w1"]):
                assert batch.poll() is None and time.monotonic() < deadline, "w1 never got a job"
                time.sleep(0.05)
            time.sleep(0.5)
            lost = list(client.processing().get(names["w1"], ()))
            os.killpg(processes["w1"].pid, signal.SIGKILL)  # the worker and its nanny, mid-job
            out, err = batch.communicate(timeout=TIMEOUT)
        finally:
            if batch.poll() is None:
                batch.kill()
    assert lost, "the worker was killed between jobs; the test needs it to die mid-job"
    assert batch.returncode == 0, err.decode()
    assert "6 jobs, 6 ok" in out.decode()

    local = make_jobs("bake", [shots / "a.toml", shots / "b.toml"], "{scene}/{wedge}.h5",
                      wedges=expand_wedges(["solver.frequency=240,480,960"]), base=tmp_path / "local")
    assert bake_many(local).ok
    farm_files = sorted(p.relative_to(tmp_path / "farm") for p in (tmp_path / "farm").rglob("*") if p.is_file())
    assert [p.as_posix() for p in farm_files] == sorted(
        ["manifest.json"] + [f"shot_{s}/frequency-{f}.h5" for s in "ab" for f in (240, 480, 960)]
    )  # no temporaries or partial files left by the killed worker
    for job in local:
        relative = Path(job.output).relative_to(tmp_path / "local")
        assert (tmp_path / "farm" / relative).read_bytes() == Path(job.output).read_bytes(), relative
