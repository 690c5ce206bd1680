"""Bake progress: plain timed lines when stderr is a log, nothing by default off a terminal."""

from __future__ import annotations

import io
import os
import re
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.cli.progress import DEFAULT_INTERVAL_S, INTERVAL_ENV, LogProgress, progress_interval
from tests.cli.test_bake_cli import scene_dir  # noqa: F401  (fixture: a 6-frame sheet scene)
from tests.conftest import REPO

LINE = re.compile(r"^bake scene\.toml: frame (\d+)/6 \((\d+)%\)(, [\d.]+ frames/s, (ETA|done in) \d+:\d\d:\d\d)?$")


class FakeClock:
    def __init__(self):
        self.now = 100.0

    def __call__(self):
        return self.now


def test_lines_every_interval_with_rate_and_eta_first_and_last_always():
    clock, stream = FakeClock(), io.StringIO()
    report = LogProgress("bake walk.toml", 10.0, stream, clock)
    for done in range(1, 49):  # one frame every 0.5 s after the first
        report(done, 48)
        clock.now += 0.5
    lines = stream.getvalue().splitlines()
    # frame 1 at t=0, then whenever 10 s have passed since the last line (frames 21 and 41), then 48
    assert [int(line.split("frame ")[1].split("/")[0]) for line in lines] == [1, 21, 41, 48]
    assert lines[0] == "bake walk.toml: frame 1/48 (2%)"
    assert lines[1] == "bake walk.toml: frame 21/48 (43%), 2.0 frames/s, ETA 0:00:14"  # 27 frames at 2/s = 13.5 s
    assert lines[3] == "bake walk.toml: frame 48/48 (100%), 2.0 frames/s, done in 0:00:24"


def test_zero_interval_reports_every_frame():
    stream = io.StringIO()
    report = LogProgress("bake x.toml", 0.0, stream, FakeClock())
    for done in range(1, 4):
        report(done, 3)
    assert len(stream.getvalue().splitlines()) == 3


def test_interval_from_the_environment(monkeypatch):
    monkeypatch.delenv(INTERVAL_ENV, raising=False)
    assert progress_interval() == DEFAULT_INTERVAL_S == 10.0
    monkeypatch.setenv(INTERVAL_ENV, "2.5")
    assert progress_interval() == 2.5
    for bad in ("soon", "-1", "nan", "inf"):
        monkeypatch.setenv(INTERVAL_ENV, bad)
        with pytest.raises(click.UsageError, match=f"{INTERVAL_ENV}='{bad}'.*set it to e.g. 10"):
            progress_interval()


def bake(scene_dir, *args, env=None):  # noqa: F811  (the fixture name as a parameter)
    return CliRunner(env=env).invoke(main, ["bake", str(scene_dir / "scene.toml"), "-o", "null", *args])


def test_progress_flag_off_a_terminal_prints_plain_lines(scene_dir):  # noqa: F811
    result = bake(scene_dir, "--progress", env={INTERVAL_ENV: "0"})
    assert result.exit_code == 0, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 6 and all(LINE.match(line) for line in lines), lines
    assert lines[0].startswith("bake scene.toml: frame 1/6 (16%)")
    assert ", done in " in lines[-1] and "frame 6/6 (100%)" in lines[-1]
    assert "\x1b" not in result.stderr  # no terminal escape codes in a log


def test_default_interval_reports_first_and_last_frame_only(scene_dir):  # noqa: F811
    result = bake(scene_dir, "--progress", env={INTERVAL_ENV: None})
    assert result.exit_code == 0, result.output
    assert [LINE.match(line).group(1) for line in result.stderr.splitlines()] == ["1", "6"]


def test_no_progress_off_a_terminal_by_default_or_when_refused(scene_dir):  # noqa: F811
    for args in ((), ("--no-progress",)):
        result = bake(scene_dir, *args, env={INTERVAL_ENV: "0"})
        assert result.exit_code == 0, result.output
        assert result.stderr == ""


def test_bad_interval_is_a_usage_error(scene_dir):  # noqa: F811
    result = bake(scene_dir, "--progress", env={INTERVAL_ENV: "often"})
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines()[-1].startswith(
        f"Error: {INTERVAL_ENV}='often' is not a number of seconds >= 0; set it to e.g. 10"
    )


@pytest.mark.slow
def test_farm_log_file_gets_the_lines(scene_dir, tmp_path):  # noqa: F811
    """A real process whose stderr is a file, as on a render farm."""
    log = tmp_path / "sub" / "bake.log"
    log.parent.mkdir()
    env = {**os.environ, INTERVAL_ENV: "0", "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    with log.open("w") as stderr:
        done = subprocess.run(
            [sys.executable, "-m", "clothtool", "bake", "scene.toml", "-o", "null", "--progress"],
            cwd=scene_dir, env=env, stdout=subprocess.PIPE, stderr=stderr, text=True,
        )
    assert done.returncode == 0, log.read_text()
    lines = log.read_text().splitlines()
    assert len(lines) == 6 and all(LINE.match(line) for line in lines), lines
    assert Path(scene_dir / "scene.toml").exists() and "bake scene -> null: ok" in done.stdout
