"""Golden fabric: a small garment cooks to exactly the stored arrays.

Regenerate after an intended change with ``CLOTHTOOL_REGEN_GOLDEN=1 python -m pytest tests/regression``
and review the diff of the JSON file.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from clothtool.cook.cooker import CookOptions, cook_fabric
from clothtool.fabric import ARRAY_FIELDS
from clothtool.mesh.shapes import grid

GOLDEN = Path(__file__).parent / "golden" / "grid4x3_fabric.json"


def cook_small():
    mesh = grid(4, 3, 0.25, quads=True)
    return cook_fabric(mesh, CookOptions(pin_box=(-0.1, -0.1, -1, 0.1, 0.1, 1), virtual_particles=1)).fabric


def as_json(fabric) -> dict:
    data = {name: getattr(fabric, name).tolist() for name, _, _ in ARRAY_FIELDS}
    data["particle_max_distance"] = ["inf" if np.isinf(v) else v for v in fabric.particle_max_distance.tolist()]
    data["cook_options"] = json.loads(fabric.cook_options)
    return data


def test_golden_fabric():
    actual = as_json(cook_small())
    if os.environ.get("CLOTHTOOL_REGEN_GOLDEN"):
        GOLDEN.write_text(json.dumps(actual, indent=1, sort_keys=True) + "\n")
    expected = json.loads(GOLDEN.read_text())
    assert actual.keys() == expected.keys()
    for name in actual:
        if name in ("rest_pos", "particle_inv_mass", "particle_area", "constraint_rest_length",
                    "tether_rest_length", "virtual_particle_weights", "face_vertex_uv"):
            np.testing.assert_allclose(np.array(actual[name], float), np.array(expected[name], float), rtol=1e-6, err_msg=name)
        else:
            assert actual[name] == expected[name], name
