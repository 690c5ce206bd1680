"""Tether lengths against exact geodesics, and their cost, for the edge graph and the unfolding.

    python benchmarks/tethers.py [--sizes 64,128,256,512] [--others]

Grids n x n of the unit square, one row per (size, pin): "edge" pins the top row (exact:
the depth), "corner" one corner and "centre" the middle particle (exact: the straight line).
Columns: mean and max relative error of the distances against the exact ones, and seconds,
for the edge graph's shortest path (scipy's dijkstra, what the cook used before) and the
unfolding (clothtool.cook.geodesic, the cook's method now). ``--others`` adds the PyPI
libraries measured before choosing, where installed: potpourri3d's heat method and fast
marching, and pygeodesic's exact MMP (point pins up to 128^2 only: 25 s at 256^2).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from clothtool.cook.geodesic import geodesic_distances
from clothtool.mesh import topology
from clothtool.mesh.shapes import grid


def sheet(n: int):
    mesh = grid(n, n, 1.0 / (n - 1))
    triangles, _ = topology.triangulate(mesh.face_vertex_counts, mesh.face_vertex_indices)
    return mesh.vertex_pos.astype(np.float64), triangles.astype(np.int64)


def pins(n: int, pos: np.ndarray):
    centre = (n // 2) * n + n // 2
    yield "edge", np.arange(n), -pos[:, 1]
    yield "corner", np.array([0]), np.linalg.norm(pos - pos[0], axis=1)
    yield "centre", np.array([centre]), np.linalg.norm(pos - pos[centre], axis=1)


def edge_graph(pos, triangles, sources):
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    edges = triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    lengths = np.linalg.norm(pos[edges[:, 1]] - pos[edges[:, 0]], axis=1)
    graph = coo_matrix((lengths, (edges[:, 0], edges[:, 1])), shape=(len(pos), len(pos))).tocsr()
    return dijkstra(graph, directed=False, indices=sources, min_only=True)


def unfolding(pos, triangles, sources):
    return geodesic_distances(pos, triangles, sources)[0]


def heat_method(pos, triangles, sources):
    import potpourri3d

    return potpourri3d.MeshHeatMethodDistanceSolver(pos, triangles).compute_distance_multisource(sources)


def fast_marching(pos, triangles, sources):
    import potpourri3d

    solver = potpourri3d.MeshFastMarchingDistanceSolver(pos, triangles)
    return solver.compute_distance([[(int(s), [])] for s in sources])


def exact_mmp(pos, triangles, sources):
    import pygeodesic.geodesic

    return pygeodesic.geodesic.PyGeodesicAlgorithmExact(pos, triangles).geodesicDistances(sources, None)[0]


def methods(others: bool):
    yield "edge graph", edge_graph
    yield "unfolding", unfolding
    if not others:
        return
    for name, module, method in (
        ("heat (pp3d)", "potpourri3d", heat_method),
        ("fmm (pp3d)", "potpourri3d", fast_marching),
        ("mmp (pygeodesic)", "pygeodesic", exact_mmp),
    ):
        try:
            __import__(module)
        except ImportError:
            print(f"({module} is not installed: no {name} rows)")
            continue
        yield name, method


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="64,128,256,512")
    parser.add_argument("--others", action="store_true", help="also the PyPI libraries, where installed")
    args = parser.parse_args()
    unfolding(*sheet(4), np.array([0]))  # compile the kernel once so no row pays for it

    print(f"{'grid':<10} {'pin':<7} {'method':<17} {'mean err %':>10} {'max err %':>10} {'seconds':>8}")
    for n in (int(s) for s in args.sizes.split(",")):
        pos, triangles = sheet(n)
        for pin, sources, exact in pins(n, pos):
            far = exact > 1e-9
            for name, method in methods(args.others):
                if name.startswith("mmp") and pin != "edge" and n > 128:
                    continue
                start = time.perf_counter()
                dist = np.asarray(method(pos, triangles, sources), np.float64).reshape(-1)
                seconds = time.perf_counter() - start
                error = np.abs(dist[far] - exact[far]) / exact[far] * 100
                print(
                    f"{n}^2{'':<{8 - len(str(n))}} {pin:<7} {name:<17} {error.mean():>10.4f} {error.max():>10.4f} {seconds:>8.3f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
