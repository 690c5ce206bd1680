"""Face collision on the README's walk example: its cost and what it buys (run from the repo root).

    python benchmarks/face_collision.py out/face_collision [--repeat 3] [--shot]

Bakes examples/skirt/walk.toml with particle collision alone (solver.face_collision = false)
and with face collision, REPEAT times each, and prints per run the collide and stats stages'
ms/frame (median over the repeats), the whole bake's simulation seconds and the face
penetration from the report. Draws OUT/walk_legs.png (benchmarks/figures/walk_legs.png): the
deepest face point inside a collider per frame for both bakes, and both skirts and the legs
cut by the horizontal plane through the particle-only bake's deepest face point at its worst frame.

With --shot, the same on a mesh collider instead: examples/shot/shot.usda (a UsdSkel-skinned
low-poly body, 552 triangles, and a skirt of 936 triangles), where face collision is the
cloth's faces against the body's vertices and edge samples (clothtool.solver.meshfaces); no figure.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from clothtool.bake import BakeOptions, bake  # noqa: E402
from clothtool.io.cache import read_cache  # noqa: E402
from clothtool.loading import load_scene  # noqa: E402
from clothtool.solver.penetration import barycentric_grid, round_cone_distance  # noqa: E402

WALK = REPO / "examples" / "skirt" / "walk.toml"
SHOT = REPO / "examples" / "shot" / "shot.usda"


def run(out: Path, face_collision: bool, repeat: int) -> dict:
    rows = []
    for _ in range(repeat):
        scene = load_scene(WALK, [f"solver.face_collision={str(face_collision).lower()}"])
        cache = out / f"walk_faces_{face_collision}.h5"
        # per-stage times need the stage-by-stage loop (a plain bake runs one compiled call a frame)
        stats = bake(scene, cache, BakeOptions(penetration=True, profile_stages=True))
        profile = {row["stage"]: row["per_frame_ms"] for row in stats.profile}
        rows.append((profile["collide"], profile["stats"], stats.simulation_s))
    report = stats.to_dict()
    overall = report["overall"]["skirt"]
    per_frame = [(f["frame"], f["cloths"]["skirt"]["max_penetration"]) for f in report["per_frame"]]
    return {
        "collide_ms": statistics.median(r[0] for r in rows),
        "stats_ms": statistics.median(r[1] for r in rows),
        "simulation_s": statistics.median(r[2] for r in rows),
        "max_penetration_mm": 1000 * overall["max_penetration"],
        "frames_beyond": overall["frames_with_faces_beyond_thickness"],
        "per_frame": per_frame,
        "cache": cache,
        "scene": scene,
    }


def run_shot(out: Path, face_collision: bool, repeat: int) -> dict:
    """The example shot's bake with or without face collision: collide ms/frame (median) and
    the face penetration of the body from the report."""
    from clothtool.loading import load_usd_scene

    rows = []
    for _ in range(repeat):
        scene = load_usd_scene(SHOT, [f"solver.face_collision={str(face_collision).lower()}"])
        stats = bake(scene, out / f"shot_faces_{face_collision}.h5", BakeOptions(penetration=True, profile_stages=True))
        profile = {row["stage"]: row["per_frame_ms"] for row in stats.profile}
        rows.append((profile["collide"], profile["stats"], stats.simulation_s))
    overall = next(iter(stats.to_dict()["overall"].values()))
    return {
        "collide_ms": statistics.median(r[0] for r in rows),
        "stats_ms": statistics.median(r[1] for r in rows),
        "simulation_s": statistics.median(r[2] for r in rows),
        "max_penetration_mm": 1000 * overall["max_penetration"],
        "frames_beyond": overall["frames_with_faces_beyond_thickness"],
    }


def contact(result: dict, frame: int) -> np.ndarray:
    """The skirt's face point deepest inside a leg at ``frame`` (sampled on a barycentric grid
    of every face): the section goes through it."""
    scene = result["scene"]
    with read_cache(result["cache"]) as reader:
        points = reader.points("skirt", frame).astype(np.float64)
    fabric = scene.cloths[0].fabric
    samples = np.einsum("gk,tkd->tgd", barycentric_grid(8), points[fabric.vertex_numbers(fabric.triangles)]).reshape(-1, 3)
    colliders = scene.colliders.at(scene.frame_time(frame))
    centres, radii = colliders.sphere_center.astype(np.float64), colliders.sphere_radius.astype(np.float64)
    ends = colliders.capsule_spheres
    distance = round_cone_distance(samples[:, None], centres[ends[:, 0]][None], centres[ends[:, 1]][None],
                                   radii[ends[:, 0]][None], radii[ends[:, 1]][None]).min(axis=1)
    return samples[np.argmin(distance)]


def hem_section(ax, result: dict, frame: int, centre: np.ndarray, title: str) -> None:
    """The skirt's faces and the legs cut by the horizontal plane through ``centre``."""
    scene = result["scene"]
    with read_cache(result["cache"]) as reader:
        points = reader.points("skirt", frame).astype(np.float64)
    fabric = scene.cloths[0].fabric
    triangles = fabric.vertex_numbers(fabric.triangles)  # the cache holds points in the mesh's vertex order
    colliders = scene.colliders.at(scene.frame_time(frame))
    centres, radii = colliders.sphere_center.astype(np.float64), colliders.sphere_radius.astype(np.float64)
    height = centre[1]
    # the skirt's section: where each triangle's edges cross y = height
    segments = []
    for tri in points[triangles]:
        above = tri[:, 1] > height
        if above.all() or not above.any():
            continue
        crossing = []
        for i, j in ((0, 1), (1, 2), (2, 0)):
            if above[i] != above[j]:
                t = (height - tri[i, 1]) / (tri[j, 1] - tri[i, 1])
                crossing.append(tri[i] + t * (tri[j] - tri[i]))
        segments.append(np.array(crossing)[:, [0, 2]])
    for segment in segments:
        ax.plot(segment[:, 0], segment[:, 1], color="#3d6fb6", lw=1.2)
    # the legs' sections: where the round cones' signed distance is negative on the plane (a
    # swinging leg's section is an ellipse, not the circle of its radius)
    x, z = np.meshgrid(np.linspace(centre[0] - 0.12, centre[0] + 0.12, 241), np.linspace(centre[2] - 0.12, centre[2] + 0.12, 241))
    plane = np.stack([x, np.full_like(x, height), z], axis=-1)
    for a, b in colliders.capsule_spheres:
        inside = round_cone_distance(plane, centres[a], centres[b], radii[a], radii[b]) <= 0.0
        if inside.any():
            ax.contourf(x, z, inside.astype(float), levels=[0.5, 1.5], colors=["#c8b8a8"], alpha=0.8)
    ax.set_xlim(centre[0] - 0.12, centre[0] + 0.12)
    ax.set_ylim(centre[2] - 0.12, centre[2] + 0.12)
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("z (m)")


def figure(off: dict, on: dict, output: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    thickness = off["scene"].cloths[0].material.thickness
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2), dpi=100)
    for result, label, colour in ((off, "particles only", "#c0392b"), (on, "face collision", "#3d6fb6")):
        frames, depth = zip(*result["per_frame"])
        axes[0].plot(frames, 1000 * np.asarray(depth), color=colour, label=label)
    axes[0].axhline(1000 * thickness, color="k", ls="--", lw=0.8, label="cloth thickness")
    axes[0].set_xlabel("frame")
    axes[0].set_ylabel("deepest face point inside a collider (mm)")
    axes[0].set_title("walk: face penetration per frame", fontsize=9)
    axes[0].legend(fontsize=8)
    worst = max(off["per_frame"], key=lambda item: item[1])[0]
    centre = contact(off, worst)
    where = f"frame {worst}, section at y = {centre[1]:.3f} m"
    hem_section(axes[1], off, worst, centre, f"particles only: {where}")
    hem_section(axes[2], on, worst, centre, f"face collision: {where}")
    fig.tight_layout()
    output.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(output, metadata={"Software": None})
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--shot", action="store_true", help="the example shot's mesh body instead of the walk")
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    runner = run_shot if args.shot else run
    off = runner(args.out, False, args.repeat)
    on = runner(args.out, True, args.repeat)
    print(f"{'shot' if args.shot else 'walk':<16} {'collide ms/fr':>13} {'stats ms/fr':>11} {'sim s':>7} {'max face depth mm':>17} {'frames beyond':>13}")
    for label, result in (("particles only", off), ("face collision", on)):
        print(f"{label:<16} {result['collide_ms']:>13.2f} {result['stats_ms']:>11.2f} {result['simulation_s']:>7.2f} "
              f"{result['max_penetration_mm']:>17.2f} {result['frames_beyond']:>13d}")
    if not args.shot:
        figure(off, on, args.out / "walk_legs.png")


if __name__ == "__main__":
    main()
