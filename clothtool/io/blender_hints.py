"""What Blender's USD importer does not take from a cache, as one-line hints for ``inspect``.

Blender's importer (File > Import > Universal Scene Description) maps one USD time code to
one Blender frame and keeps the scene's own frame rate: the stage's ``timeCodesPerSecond``
is not read, and "Set Frame Range" copies only the start and end. A cache baked at 30 fps
plays at 24 fps (Blender's default) until the scene's rate is set. ``metersPerUnit`` is
applied only when the import option "Apply Unit Conversion Scale" is on; with it off, one
scene unit becomes one metre. HDF5 caches are not read by Blender at all, so only USD
containers get hints.
"""

from __future__ import annotations

BLENDER_FPS = 24.0  # a new Blender scene's frame rate
USD_CONTAINERS = ("usd", "usda", "usdc")


def blender_hints(container: str, fps: float, meters_per_unit: float) -> list[str]:
    """One line per piece of a USD cache's metadata Blender's importer would leave out."""
    if container not in USD_CONTAINERS:
        return []
    hints = []
    if fps != BLENDER_FPS:
        hints.append(
            f"Blender keeps the scene's frame rate (24 fps by default) and plays one time code per frame: "
            f"set the scene's frame rate to {fps:g} fps to play this cache at its speed"
        )
    if meters_per_unit != 1.0:
        hints.append(
            f"Blender applies metersPerUnit {meters_per_unit:g} only with the import option "
            f"'Apply Unit Conversion Scale'; with it off, set the import Scale to {meters_per_unit:g}"
        )
    return hints
