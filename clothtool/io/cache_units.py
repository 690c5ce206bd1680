"""What the numbers in a cache mean: the ``units`` (and ``frame``) written beside each dataset.

The HDF5 writer puts these strings on every dataset as attributes and the USD writer on its
custom attributes as customData, so a file read without clothtool's docs still says what its
numbers are. Lengths are in scene units, and the string gives the size of one in metres.
Stats follow the bake's report: speeds in m/s, energies in J, strains as fractions.
Velocities are in world space; speeds and energies in the stats are measured in the cloth's
frame (the world for a cloth without a track, else the moving frame the track gives it), as
the bake's stability check measures them.

    lengths(0.01)        -> "scene units (0.01 m)"
    stat_units("max_strain") -> ("fraction (0.01 = 1%)", None)
"""

from __future__ import annotations

FRACTION = "fraction (0.01 = 1%)"
# The frame a stat's speeds are measured in: the cloth's own (see the module docstring).
CLOTH_FRAME = "cloth"
WORLD_FRAME = "world"
# A stat or primvar a caller invented: the writer cannot know its units.
UNSPECIFIED = "not specified by the writer"

# The painted pin map as exported: 1 for a pinned point (inverse mass 0), 0 for a free one.
PIN_PRIMVAR = "pin"
PIN_UNITS = "1 = pinned, 0 = free"

_STATS = {
    "max_speed": ("m/s", CLOTH_FRAME),
    "kinetic_energy": ("J", CLOTH_FRAME),
    "max_strain": (FRACTION, None),
    "tether_stretch": (FRACTION, None),
}


def lengths(meters_per_unit: float) -> str:
    return f"scene units ({meters_per_unit:g} m)"


def velocities(meters_per_unit: float) -> str:
    return f"scene units per second ({meters_per_unit:g} m/s)"


def stat_units(field: str) -> tuple[str, str | None]:
    """(units, frame or None) of a per-frame stats field."""
    return _STATS.get(field, (UNSPECIFIED, None))


def primvar_units(key: str, meters_per_unit: float) -> str:
    if key == PIN_PRIMVAR:
        return PIN_UNITS
    if key == "max_distance":
        return f"{lengths(meters_per_unit)}; -1 = unbounded"
    return UNSPECIFIED


def xform(meters_per_unit: float) -> str:
    return f"4x4 matrix, row vectors; translation (last row) in {lengths(meters_per_unit)}"


def planes(meters_per_unit: float) -> str:
    return f"(nx, ny, nz) unit outward normal, d in {lengths(meters_per_unit)}"


FACE_VERTEX_COUNTS = "vertices per face"
FACE_VERTEX_INDICES = "point index"
FACE_VERTEX_UV = "texture coordinates (u, v)"
