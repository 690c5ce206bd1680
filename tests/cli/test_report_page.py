"""The HTML report shows every figure the README's ``--report`` row promises, with the JSON's value.

The page is parsed with the stdlib's html.parser; value cells carry their JSON path in
``data-key``, and the number shown must equal the JSON value to the precision shown.
"""

from __future__ import annotations

import copy
import json
import re
from html.parser import HTMLParser

import pytest
from click.testing import CliRunner

from clothtool.cli import main
from clothtool.report import write_report
from clothtool.report_html import render_html
from tests.cli.test_bake_cli import scene_dir  # noqa: F401  (fixture: a 6-frame sheet scene)

NUMBER = re.compile(r"^(-?\d+(?:\.(\d+))?(?:e([+-]?\d+))?)\s*(%|M|m/s|J|s|ms)?$")
SCALE = {None: 1.0, "%": 0.01, "M": 1e6, "m/s": 1.0, "J": 1.0, "s": 1.0, "ms": 1.0}


class Page(HTMLParser):
    """Collects value cells (data-key -> text), headings, figures and anything that loads."""

    def __init__(self, text: str):
        super().__init__()
        self.values: dict[str, str] = {}
        self.headings: list[str] = []
        self.figures_with_svg = 0
        self.loads: list[str] = []  # scripts, stylesheets, images: the page must need nothing else
        self._key = self._heading = None
        self._text = ""
        self._in_figure = False
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag in ("script", "link", "img", "iframe") or "src" in attrs:
            self.loads.append(tag)
        if "data-key" in attrs:
            self._key, self._text = attrs["data-key"], ""
        if tag in ("h2", "h3"):
            self._heading, self._text = tag, ""
        if tag == "figure":
            self._in_figure = True
        if tag == "svg" and self._in_figure:
            self.figures_with_svg += 1

    def handle_endtag(self, tag):
        if tag == "td" and self._key is not None:
            self.values[self._key] = self._text.strip()
            self._key = None
        if tag == self._heading:
            self.headings.append(self._text.strip())
            self._heading = None
        if tag == "figure":
            self._in_figure = False

    def handle_data(self, data):
        self._text += data


def lookup(report: dict, key: str):
    value = report
    for part in key.split("/"):
        value = value[int(part)] if isinstance(value, list) else value[part]
    return value


def assert_shows(page: Page, report: dict, key: str) -> None:
    """The cell for ``key`` shows the JSON value, rounded as written on the page."""
    assert key in page.values, f"{key} is not on the page"
    text = page.values[key]
    match = NUMBER.match(text)
    assert match, f"{key}: '{text}' is not a number with a unit"
    number, decimals, exponent, unit = match.groups()
    step = 10.0 ** (-len(decimals or "") + int(exponent or 0))  # one unit of the last digit shown
    shown = float(number) * SCALE[unit]
    assert abs(shown - lookup(report, key)) <= 0.5 * step * SCALE[unit] * (1 + 1e-9), (key, text, lookup(report, key))


@pytest.fixture
def report(scene_dir, tmp_path) -> dict:  # noqa: F811
    path = tmp_path / "sub" / "report.json"
    path.parent.mkdir()
    result = CliRunner().invoke(main, ["bake", str(scene_dir / "scene.toml"), "-o", "null", "--report", str(path)])
    assert result.exit_code == 0, result.output
    return json.loads(path.read_text())


def test_every_promised_figure_is_on_the_page_with_the_json_value(report, tmp_path):
    html_path = tmp_path / "sub" / "report.html"
    write_report(report, html_path)
    page = Page(html_path.read_text())

    overall = report["overall"]["sheet"]
    assert set(overall["strain"]) == {"horizontal", "shearing", "bending"}
    for label, stats in overall["strain"].items():
        assert set(stats) == {"max", "mean", "p99"}
        for stat in stats:
            assert_shows(page, report, f"overall/sheet/strain/{label}/{stat}")
    for key in ("max_tether_stretch", "max_speed", "max_kinetic_energy"):
        assert_shows(page, report, f"overall/sheet/{key}")
    for key in ("wall_s", "cpu_s", "jit_warm_up_s", "simulation_s", "frames_per_second", "particle_iterations_per_second"):
        assert_shows(page, report, f"timing/{key}")
    for key in ("iterations_per_frame", "frames/simulated", "cloths/sheet/particles"):
        assert_shows(page, report, key)
    assert page.values["overall/sheet/finite"] == "all positions finite"
    assert page.values["stages"] == ", ".join(report["stages"]) == "integrate, wind, tethers, fabric"
    assert page.values["status"] == "ok"

    # JIT warm-up happens once: its row gives seconds in total, never a per-frame figure
    jit = next(i for i, row in enumerate(report["profile"]) if row["stage"] == "jit warm-up")
    assert page.values[f"profile/{jit}/total_s"].endswith(" s")
    assert_shows(page, report, f"profile/{jit}/total_s")
    assert page.values[f"profile/{jit}/per_frame_ms"] == "-"
    # without --profile a frame's iterations run in one compiled call, timed as "frame"
    frame = next(i for i, row in enumerate(report["profile"]) if row["stage"] == "frame")
    assert_shows(page, report, f"profile/{frame}/per_frame_ms")

    plots = ["Strain per phase type (max; p99 dashed)", "Max particle speed", "Kinetic energy", "Max tether stretch",
             "Time per stage per frame (JIT warm-up apart)"]
    assert [h for h in page.headings if h in plots] == plots
    assert page.figures_with_svg == len(plots)
    assert page.loads == []  # self-contained: no scripts, stylesheets or images to fetch
    assert str(tmp_path) not in html_path.read_text()


def test_same_report_same_bytes(report):
    assert render_html(report) == render_html(copy.deepcopy(report))


def test_nan_check_names_the_first_bad_frame_and_particle(report):
    broken = copy.deepcopy(report)
    frame = broken["per_frame"][2]
    frame["cloths"]["sheet"].update(finite=False, nonfinite_particle=17)
    broken["overall"]["sheet"]["finite"] = False
    page = Page(render_html(broken))
    assert page.values["overall/sheet/finite"] == f"NaN/Inf at frame {frame['frame']} (particle 17)"


def test_failure_and_partial_output_are_shown(report):
    failed = copy.deepcopy(report)
    failed.update(status="unstable", failure={"frame": 4, "message": "sheet: unstable at frame 4 <&>"},
                  partial_output="x.partial.h5")
    page = Page(render_html(failed))
    assert page.values["status"] == "unstable"
    assert page.values["failure/message"] == "sheet: unstable at frame 4 <&>"  # escaped in HTML, intact as text
    assert page.values["partial_output"] == "x.partial.h5"
