"""References for clothtool/solver/kernels/collide_cull.py (numpy, float64)."""

from __future__ import annotations

import numpy as np

from tests.reference.collide_mesh import box_cells, to_world

SLACK = 1e-4


def run_end(virtual, r):
    same = (virtual[r + 1:, :3] == virtual[r, :3]).all(axis=1)
    return r + 1 + (int(np.argmin(same)) if not same.all() else same.shape[0])


def triangle_ball(cur, prev, a, b, c):
    corners = np.vstack([cur[[a, b, c], :3], prev[[a, b, c], :3]]).astype(np.float64)
    centre = corners[:3].mean(axis=0)
    return (*centre, float(np.linalg.norm(corners - centre, axis=1).max()))


def impact_tolerance(radius):
    return 1e-4 * radius + 1e-9


def triangle_box(cur, prev, a, b, c):
    corners = np.vstack([cur[[a, b, c], :3], prev[[a, b, c], :3]]).astype(np.float64)
    return (*corners.min(axis=0), *corners.max(axis=0))


def _grow_box(out, k, x, y, z, r):
    out[k, :3] = np.minimum(out[k, :3], np.array([x, y, z]) - r)
    out[k, 3:] = np.maximum(out[k, 3:], np.array([x, y, z]) + r)


def collider_boxes(sphere_data, capsule_data, swept, out):
    balls = [np.asarray(sphere_data, np.float64)[:, [4, 5, 6, 7, 0, 1, 2, 3]]]
    balls.append(np.asarray(capsule_data, np.float64)[:, [8, 9, 10, 11, 12, 13, 14, 15, 0, 1, 2, 3, 4, 5, 6, 7]])
    rows = [(row.reshape(-1, 4), 0.0) for row in balls[0]]
    rows += [(row.reshape(-1, 4), 1.0) for row in balls[1]]
    for k, (spheres, capsule) in enumerate(rows):
        used = spheres if swept else spheres[: 2 if capsule else 1]
        out[k, :3] = (used[:, :3] - used[:, 3:]).min(axis=0)
        out[k, 3:] = (used[:, :3] + used[:, 3:]).max(axis=0)
        tolerance = (1e-4 * np.abs(used[:, 3]).max() + 1e-9) if swept and capsule else 0.0
        grow = tolerance + SLACK * np.abs(out[k]).sum()
        out[k, :3] -= grow
        out[k, 3:] += grow


def boxes_miss(lx, ly, lz, hx, hy, hz, boxes):
    box = np.array([lx, ly, lz, hx, hy, hz], np.float64)
    grow = SLACK * np.abs(box).sum()
    lo, hi = box[:3] - grow, box[3:] + grow
    return all(((lo > row[3:]) | (hi < row[:3])).any() for row in np.asarray(boxes))


def segment_distance(px, py, pz, ax, ay, az, bx, by, bz):
    p, a, b = np.array([px, py, pz], float), np.array([ax, ay, az], float), np.array([bx, by, bz], float)
    e = b - a
    t = 0.0 if e @ e == 0 else float(np.clip((p - a) @ e / (e @ e), 0.0, 1.0))
    return float(np.linalg.norm(p - a - t * e))


def _far(gap, scale):
    return gap > SLACK * scale


def spheres_far(cx, cy, cz, radius, sphere_data, swept):
    for s in np.asarray(sphere_data, np.float64):
        scale = abs(cx) + abs(cy) + abs(cz) + radius + np.abs(s[4:8]).sum()
        if swept:
            distance, reach = segment_distance(cx, cy, cz, *s[0:3], *s[4:7]), max(s[3], s[7])
            scale += np.abs(s[0:4]).sum()
        else:
            distance, reach = float(np.linalg.norm([cx - s[4], cy - s[5], cz - s[6]])), s[7]
        if not _far(distance - radius - reach, scale):
            return False
    return True


def capsules_far(cx, cy, cz, radius, capsule_data, swept):
    for c in np.asarray(capsule_data, np.float64):
        distance = segment_distance(cx, cy, cz, *c[8:11], *c[12:15])
        scale = abs(cx) + abs(cy) + abs(cz) + radius + np.abs(c[8:16]).sum()
        reach = max(c[11], c[15])
        if swept:
            d0 = segment_distance(cx, cy, cz, *c[0:3], *c[4:7])
            travel = max(np.linalg.norm(c[8:11] - c[0:3]), np.linalg.norm(c[12:15] - c[4:7]))
            distance = 0.5 * (d0 + distance - travel)
            scale += np.abs(c[0:8]).sum()
            reach = max(reach, c[3], c[7]) + 1e-4 * max(c[3], c[7], c[11], c[15]) + 1e-9
        if not _far(distance - radius - reach, scale):
            return False
    return True


def convexes_far(cx, cy, cz, radius, planes, offsets, convex_data):
    centre = np.array([cx, cy, cz])
    for k in range(len(offsets) - 1):
        margin = float(convex_data[k][0])
        rows = np.asarray(planes[offsets[k]:offsets[k + 1]], np.float64)
        if rows.shape[0] == 0:
            continue
        length = np.linalg.norm(rows[:, :3], axis=1)
        gap = rows[:, :3] @ centre - rows[:, 3] - margin - radius * length
        scale = (np.abs(centre).sum() + radius + abs(margin)) * (length + 1.0) + np.abs(rows[:, 3])
        if not (gap > SLACK * scale).any():
            return False
    return True


def mesh_far(cx, cy, cz, radius, cell_start, grid, frame):
    w0, w1 = np.array(to_world(frame, 0, cx, cy, cz)), np.array(to_world(frame, 1, cx, cy, cz))
    grow = radius + SLACK * (np.abs(w0).sum() + np.abs(w1).sum() + abs(cx) + abs(cy) + abs(cz) + radius)
    lo, hi = np.minimum(w0, w1) - grow, np.maximum(w0, w1) + grow
    outside, i0, j0, k0, i1, j1, k1 = box_cells(lo, hi, grid)
    if outside:
        return True
    nx, ny = int(grid[4]), int(grid[5])
    for k in range(k0, k1 + 1):
        for j in range(j0, j1 + 1):
            for i in range(i0, i1 + 1):
                cell = (k * ny + j) * nx + i
                if cell_start[cell + 1] > cell_start[cell]:
                    return False
    return True
