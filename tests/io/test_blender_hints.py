"""``clothtool inspect`` lists the cache metadata Blender's USD importer leaves out (the frame
rate; metersPerUnit unless the import option is on), one line each, and nothing when there is
nothing to say."""

from __future__ import annotations

import dataclasses
import json

import pytest
from click.testing import CliRunner
from test_cache_roundtrip import make_header, write_cache

from clothtool.cli import main
from clothtool.io.blender_hints import blender_hints


def _inspect(path, *args):
    result = CliRunner().invoke(main, ["inspect", str(path), *args])
    assert result.exit_code == 0, result.output
    return result.output


def test_a_30_fps_centimetre_usd_cache_gets_both_hints(out_dir):
    path = out_dir / "shot.usdc"
    write_cache(path, make_header(), count=2)  # 30 fps, 0.01 m per unit
    notes = [line for line in _inspect(path).splitlines() if line.startswith("  note ")]
    assert notes == [
        "  note       Blender keeps the scene's frame rate (24 fps by default) and plays one time code per frame: "
        "set the scene's frame rate to 30 fps to play this cache at its speed",
        "  note       Blender applies metersPerUnit 0.01 only with the import option 'Apply Unit Conversion Scale'; "
        "with it off, set the import Scale to 0.01",
    ]
    summary = json.loads(_inspect(path, "--json"))
    assert summary["blender_hints"] == [note.removeprefix("  note       ") for note in notes]


def test_a_24_fps_metre_usd_cache_needs_no_hint(out_dir):
    path = out_dir / "shot.usda"
    write_cache(path, dataclasses.replace(make_header(), fps=24.0, meters_per_unit=1.0), count=2)
    text = _inspect(path)
    assert "note" not in text and json.loads(_inspect(path, "--json"))["blender_hints"] == []


def test_hdf5_caches_get_no_blender_hint(out_dir):
    # Blender does not import HDF5 caches: nothing of theirs is "ignored" by it
    path = out_dir / "shot.h5"
    write_cache(path, make_header(), count=2)
    assert "note" not in _inspect(path)


@pytest.mark.parametrize("fps, meters_per_unit, expected", [(24.0, 0.01, ["metersPerUnit 0.01"]), (25.0, 1.0, ["to 25 fps"])])
def test_each_hint_only_when_its_value_differs(fps, meters_per_unit, expected):
    hints = blender_hints("usdc", fps, meters_per_unit)
    assert len(hints) == len(expected) and all(text in hint for text, hint in zip(expected, hints))
