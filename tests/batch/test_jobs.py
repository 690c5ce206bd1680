"""Job descriptions: input globs, output templates, wedge expansion and naming."""

from __future__ import annotations

from pathlib import Path

import pytest

from clothtool.batch.jobs import check_distinct_outputs, expand_inputs, expand_wedges, make_jobs, wedge_label
from clothtool.errors import ClothtoolError


def test_wedges_are_the_cartesian_product_first_key_slowest():
    wedges = expand_wedges(["solver.frequency=300,600", "solver.stiffness_mode=nvcloth,xpbd"])
    assert wedges == [
        (("solver.frequency", 300), ("solver.stiffness_mode", "nvcloth")),
        (("solver.frequency", 300), ("solver.stiffness_mode", "xpbd")),
        (("solver.frequency", 600), ("solver.stiffness_mode", "nvcloth")),
        (("solver.frequency", 600), ("solver.stiffness_mode", "xpbd")),
    ]


def test_zipped_wedges_pair_values_and_multiply_the_product():
    wedges = expand_wedges(["solver.frequency=300,600"], ["a.x=1,2,3", "a.y=0.5,0.25,0.125"])
    assert len(wedges) == 6
    assert wedges[0] == (("solver.frequency", 300), ("a.x", 1), ("a.y", 0.5))
    assert wedges[5] == (("solver.frequency", 600), ("a.x", 3), ("a.y", 0.125))
    with pytest.raises(ClothtoolError, match="equal lengths"):
        expand_wedges([], ["a.x=1,2", "a.y=1"])
    with pytest.raises(ClothtoolError, match="wedged twice"):
        expand_wedges(["a.x=1"], ["a.x=2"])
    with pytest.raises(ClothtoolError, match="KEY=V1,V2"):
        expand_wedges(["solver.frequency"])
    assert expand_wedges() == [()]


def test_wedge_labels_are_file_name_safe_and_distinct():
    assert wedge_label(()) == "base"
    assert wedge_label((("solver.frequency", 300), ("solver.stiffness_mode", "xpbd"))) == "frequency-300_stiffness_mode-xpbd"
    assert wedge_label((("solver.damping", 0.25),)) == "damping-0.25"
    assert wedge_label((("a.k", 1), ("b.k", 2))) == "a-k-1_b-k-2"  # same last component: full keys
    assert wedge_label((("cloth.sheet.material", "silk/heavy"),)) == "material-silk-heavy"


def test_template_names_outputs_from_scene_name_file_name_and_wedge(shots, tmp_path):
    wedges = expand_wedges(["solver.frequency=300,600"])
    jobs = make_jobs("bake", [shots / "a.toml", shots / "b.toml"], "caches/{scene}/{name}-{wedge}.usdc",
                     wedges=wedges, base=tmp_path)
    outputs = [Path(j.output).relative_to(tmp_path).as_posix() for j in jobs]
    assert outputs == [
        "caches/shot_a/a-frequency-300.usdc", "caches/shot_a/a-frequency-600.usdc",
        "caches/shot_b/b-frequency-300.usdc", "caches/shot_b/b-frequency-600.usdc",
    ]
    assert jobs[1].wedge_overrides == ["solver.frequency=600"]
    assert jobs[1].settings()["wedge"] == {"solver.frequency": 600}


def test_template_errors_name_the_field_and_collisions_name_the_fix(shots, tmp_path):
    with pytest.raises(ClothtoolError, match=r"unknown template field '\{shot\}'"):
        make_jobs("bake", [shots / "a.toml"], "out/{shot}.usdc")
    jobs = make_jobs("bake", [shots / "a.toml"], "out/{scene}.usdc", wedges=expand_wedges(["solver.frequency=300,600"]))
    with pytest.raises(ClothtoolError, match=r"would both write it; add \{name\}, \{scene\} or \{wedge\}"):
        check_distinct_outputs(jobs)
    with pytest.raises(ClothtoolError, match="bakes only"):
        make_jobs("cook", [shots / "a.toml"], "out/{name}.fabric.h5", wedges=expand_wedges(["weld=0.1,0.2"]))


def test_globs_expand_sorted_once_and_empty_patterns_fail(shots):
    found = expand_inputs(["*.toml", "a.toml"], base=shots)
    assert [p.name for p in found] == ["a.toml", "b.toml", "broken.toml"]
    assert [p.name for p in expand_inputs(["missing.toml"], base=shots)] == ["missing.toml"]  # fails later, alone
    with pytest.raises(ClothtoolError, match="matches no file"):
        expand_inputs(["*.obj"], base=shots)
