"""How deep the baked cloth goes into the body of a USD shot, frame by frame.

    clothtool bake examples/shot/shot.usda -o /tmp/x.usdc
    python benchmarks/shot_penetration.py examples/shot/shot.usda /tmp/x.usdc

For every written frame: the cloth's vertices and points along its edges (quarter, half,
three quarters) in world space, read from the layer over the shot; the body's mesh as the
bake saw it (clothtool's USD stage loader: UsdSkel skinning at that frame). A point is inside
the body when the generalized winding number of a closed part of the body (a connected
component: torso, legs) is above 1/2 in magnitude (Van Oosterom & Strackee solid angles;
either face orientation: the example's body is wound inwards, -1 inside); its depth is the
distance to that part's surface (trimesh's exact point-triangle closest points). The
deepest point per frame over all parts is a lower bound of the depth below the union's
surface. Pinned particles (bound to the body at the waist) are reported apart. Clearances are
the smallest distances of the free samples, and of the free vertices alone, to the body's
surface (the bake keeps vertices a body thickness plus a cloth thickness away).
"""

from __future__ import annotations

import sys

import numpy as np
import trimesh
from pxr import Usd, UsdGeom
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from clothtool.loading import load_usd_scene


def winding_numbers(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(p,) generalized winding numbers of ``points`` w.r.t. the (t,3,3) triangles."""
    a = triangles[None, :, 0, :] - points[:, None, :]
    b = triangles[None, :, 1, :] - points[:, None, :]
    c = triangles[None, :, 2, :] - points[:, None, :]
    la, lb, lc = (np.linalg.norm(v, axis=2) for v in (a, b, c))
    det = np.einsum("ptk,ptk->pt", a, np.cross(b, c))
    div = la * lb * lc + np.einsum("ptk,ptk->pt", a, b) * lc + np.einsum("ptk,ptk->pt", b, c) * la + np.einsum("ptk,ptk->pt", c, a) * lb
    return (2.0 * np.arctan2(det, div)).sum(axis=1) / (4.0 * np.pi)


def distances(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """(p,) distance from each point to the nearest of the (t,3,3) triangles."""
    p, t = points.shape[0], triangles.shape[0]
    closest = trimesh.triangles.closest_point(np.repeat(triangles[None], p, 0).reshape(-1, 3, 3), np.repeat(points, t, 0))
    return np.linalg.norm(closest - np.repeat(points, t, 0), axis=1).reshape(p, t).min(axis=1)


def parts(triangles: np.ndarray, count: int) -> list[np.ndarray]:
    """Triangle index lists of the connected components."""
    rows = np.repeat(triangles, 3, axis=0).ravel()
    cols = np.roll(triangles, 1, axis=1).repeat(3, axis=0).ravel()
    graph = coo_matrix((np.ones(rows.size), (rows, cols)), shape=(count, count))
    _, label = connected_components(graph, directed=False)
    tri_label = label[triangles[:, 0]]
    return [np.flatnonzero(tri_label == k) for k in np.unique(tri_label)]


def main(shot: str, layer: str) -> None:
    scene = load_usd_scene(shot)
    cloth = scene.cloths[0]
    body = next(c for c in scene.colliders.colliders if c.kind == "mesh")
    body_parts = parts(body.mesh_triangles, body.mesh_points.shape[0])
    stage = Usd.Stage.Open(layer)
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath(cloth.prim))
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get())
    indices = np.asarray(mesh.GetFaceVertexIndicesAttr().Get())
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    edges = set()
    for s, n in zip(starts, counts):
        face = indices[s : s + n]
        edges.update(tuple(sorted((int(face[i]), int(face[(i + 1) % n])))) for i in range(n))
    edges = np.array(sorted(edges))
    pinned_vertex = cloth.fabric.particle_inv_mass[cloth.vertex_particle] == 0
    pinned_sample = np.concatenate([pinned_vertex] + [pinned_vertex[edges[:, 0]] & pinned_vertex[edges[:, 1]]] * 3)
    print(f"cloth {cloth.prim}: {len(pinned_vertex)} vertices ({pinned_vertex.sum()} pinned), {len(edges)} edges; "
          f"body {body.name}: {body.mesh_triangles.shape[0]} triangles in {len(body_parts)} closed parts; "
          f"thickness: body {body.thickness:g}, cloth {cloth.material.thickness:g} (scene units, {scene.meters_per_unit:g} m)")
    print("frame  inside(free)  inside(pinned)  deepest free [mm]  deepest pinned [mm]  free clearance [mm]  vertex clearance [mm]")
    worst, worst_vertex = (0.0, None), 0.0
    for frame in range(scene.start_frame, scene.end_frame + 1):
        time = frame / scene.fps
        local = np.asarray(mesh.GetPointsAttr().Get(Usd.TimeCode(frame)), np.float64)
        m = np.array(mesh.ComputeLocalToWorldTransform(Usd.TimeCode(frame)), np.float64)
        vertices = local @ m[:3, :3] + m[3, :3]
        a, b = vertices[edges[:, 0]], vertices[edges[:, 1]]
        samples = np.concatenate([vertices] + [a + u * (b - a) for u in (0.25, 0.5, 0.75)])
        m_body = body.matrix(time)
        body_points = body.local_points(time) @ m_body[:3, :3].T + m_body[:3, 3]
        depth = np.zeros(samples.shape[0])
        clearance = distances(samples[~pinned_sample], body_points[body.mesh_triangles]).min()
        vertex_clearance = distances(vertices[~pinned_vertex], body_points[body.mesh_triangles]).min()
        for part in body_parts:
            tris = body_points[body.mesh_triangles[part]]
            inside = np.abs(winding_numbers(samples, tris)) > 0.5  # either orientation
            if inside.any():
                depth[inside] = np.maximum(depth[inside], distances(samples[inside], tris))
        inside = depth > 0
        free, pin = inside & ~pinned_sample, inside & pinned_sample
        deep_free = depth[~pinned_sample].max() * scene.meters_per_unit * 1000
        deep_pin = depth[pinned_sample].max() * scene.meters_per_unit * 1000 if pinned_sample.any() else 0.0
        vertex_depth = depth[: vertices.shape[0]][~pinned_vertex].max() * scene.meters_per_unit * 1000
        worst_vertex = max(worst_vertex, vertex_depth)
        print(f"{frame:5d}  {free.sum():12d}  {pin.sum():14d}  {deep_free:17.2f}  {deep_pin:19.2f}  {clearance * scene.meters_per_unit * 1000:19.2f}  {vertex_clearance * scene.meters_per_unit * 1000:21.2f}")
        if deep_free > worst[0]:
            worst = (deep_free, frame)
    print(f"deepest free cloth point inside the body: {worst[0]:.2f} mm at frame {worst[1]}; deepest vertex {worst_vertex:.2f} mm")


if __name__ == "__main__":
    main(*sys.argv[1:3])
