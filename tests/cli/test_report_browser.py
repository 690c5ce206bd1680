"""The HTML report in a real browser (headless Chromium, when installed): a screenshot of the
right size that is not blank, and no text overflowing its box, even with very long names."""

from __future__ import annotations

import copy
import importlib.util
import json
import shutil

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from clothtool.cli import main
from clothtool.report import write_report
from tests.cli.test_bake_cli import scene_dir  # noqa: F401  (fixture: a 6-frame sheet scene)
from tests.conftest import REPO

pytestmark = pytest.mark.skipif(
    shutil.which("chromium") is None, reason="headless Chromium not installed (Debian: apt-get install chromium)"
)


def load_script():
    spec = importlib.util.spec_from_file_location("report_screenshot", REPO / "benchmarks" / "report_screenshot.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def screenshot_script():
    return load_script()


@pytest.fixture
def report(scene_dir, tmp_path) -> dict:  # noqa: F811
    path = tmp_path / "sub" / "report.json"
    path.parent.mkdir()
    result = CliRunner().invoke(main, ["bake", str(scene_dir / "scene.toml"), "-o", "null", "--report", str(path)])
    assert result.exit_code == 0, result.output
    return json.loads(path.read_text())


def test_screenshot_is_the_window_size_and_shows_the_page(screenshot_script, report, tmp_path):
    page, png = tmp_path / "sub" / "report.html", tmp_path / "sub" / "report.png"
    write_report(report, page)
    assert screenshot_script.main([str(page), "-o", str(png), "--size", "1280x2400"]) == 0
    pixels = np.asarray(Image.open(png).convert("L"), dtype=np.float64)
    assert pixels.shape == (2400, 1280)
    dark = pixels < 128  # text, table rules, plot lines on a white page
    assert 0.005 < dark.mean() < 0.5
    assert dark[:150].any()  # the title at the top
    rows_with_ink = np.flatnonzero(dark.any(axis=1))
    assert rows_with_ink[-1] > 1200  # tables and plots fill the page, not just a heading


def test_long_names_and_messages_wrap_inside_their_boxes(screenshot_script, report, tmp_path):
    long = copy.deepcopy(report)
    long.update(
        scene="scene_" + "w" * 150, output="shots/" + "o" * 300 + ".usdc", status="unstable",
        failure={"frame": 3, "message": "sheet: " + "m" * 400 + " exceeded max speed"},
        partial_output="p" * 250 + ".partial.usdc",
    )
    page = tmp_path / "sub" / "long.html"
    write_report(long, page)
    for width in (1280, 700):
        assert screenshot_script.overflowing(page, width) == []


def test_the_overflow_check_sees_overflowing_text(screenshot_script, tmp_path):
    page = tmp_path / "sub" / "bad.html"
    page.parent.mkdir()
    page.write_text('<!DOCTYPE html><html><body><pre style="width:20em">' + "x" * 300 + "</pre></body></html>")
    problems = screenshot_script.overflowing(page, 800)
    assert any(p.startswith("pre: xxx") for p in problems), problems


def test_missing_page_is_one_error_line(screenshot_script, tmp_path, capsys):
    assert screenshot_script.main([str(tmp_path / "nope.html"), "-o", str(tmp_path / "x.png")]) == 1
    assert capsys.readouterr().err.strip().endswith("nope.html: no such file; give the .html written by clothtool bake --report")
