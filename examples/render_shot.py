"""Render one frame of a baked shot to a PNG with matplotlib (run from the repository root).

    python examples/render_shot.py examples/shot/shot.usda out/shot_cloth.usdc 30 out/shot.png

The body comes from the shot as clothtool's loader poses it (pxr's UsdSkel skinning); the
cloth from the cache (a layer over the shot or a plain cache), as pxr composes it.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def cloth_faces(cache: Path, frame: int):
    """World points and faces of every garment Mesh the cache layer overrides."""
    from pxr import Usd, UsdGeom

    stage = Usd.Stage.Open(str(cache))
    shapes = []
    for prim in stage.Traverse():
        if not prim.IsA(UsdGeom.Mesh) or prim.GetAttribute("clothtool:role").Get() != "cloth":
            continue
        mesh = UsdGeom.Mesh(prim)
        local = np.array(mesh.GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
        counts = np.array(mesh.GetFaceVertexCountsAttr().Get())
        indices = np.array(mesh.GetFaceVertexIndicesAttr().Get())
        starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
        shapes.append((local @ m[:3, :3] + m[3, :3], [indices[s:s + c] for s, c in zip(starts, counts)]))
    return shapes


def render(shot: Path, cache: Path, frame: int, output: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    from clothtool.loading import load_usd_scene

    scene = load_usd_scene(shot)
    body = scene.colliders.at(frame / scene.fps)
    figure = plt.figure(figsize=(9, 6), dpi=100)
    for column, azimuth in enumerate((-60, 20)):
        axes = figure.add_subplot(1, 2, column + 1, projection="3d")
        # USD is Y up; matplotlib draws Z up: plot (x, z, y)
        swap = [0, 2, 1]
        body_points = body.mesh_points[:, swap]
        polygons = list(body_points[body.mesh_triangles])
        colours = [("#c8b8a8", "#8a7a6a")] * len(polygons)
        for points, faces in cloth_faces(cache, frame):
            polygons += [points[f][:, swap] for f in faces]
            colours += [("#3d6fb6", "#1d3f76")] * len(faces)
        # one collection: matplotlib sorts polygons by depth within a collection only, so the
        # body and the skirt in two would draw one wholly over the other
        axes.add_collection3d(Poly3DCollection(polygons, facecolors=[c for c, _ in colours],
                                               edgecolors=[e for _, e in colours], linewidths=0.25, alpha=0.9), autolim=False)
        centre = body_points.mean(axis=0)
        for set_limits, axis in ((axes.set_xlim, 0), (axes.set_ylim, 1), (axes.set_zlim, 2)):
            set_limits(centre[axis] - 0.8, centre[axis] + 0.8)
        axes.set_box_aspect((1, 1, 1))
        axes.view_init(elev=12, azim=azimuth)
        axes.set_axis_off()
    figure.suptitle(f"{shot.name} frame {frame}: UsdSkel body, baked skirt ({cache.name})")
    figure.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(output, metadata={"Software": None})
    plt.close(figure)


if __name__ == "__main__":
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    render(Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3]), Path(sys.argv[4]))
