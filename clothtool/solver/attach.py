"""Attachments: pinned particles follow an animated body, and painted max-distance
(motion) constraints are centred on the body, as games drive NvCloth's motion constraints
from the skinned mesh.

At the rest pose each bound particle binds to its closest body triangle: the barycentric
coordinates of its projection onto the triangle's plane plus its offset along the
triangle's unit normal, so that the binding reproduces the rest position exactly and moves
with the triangle as the body deforms. Each iteration the attached positions are
interpolated between the frame's start and end body poses (as collision interpolates the
colliders), pinned particles are put there, and the motion stage uses them as centres.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.errors import SceneError
from clothtool.solver.framefn import FusedCall, stacked
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.attach import attach_particles
from clothtool.solver.stage import Stage

_CHUNK = 64  # particles per block of the brute-force closest-triangle search


@dataclasses.dataclass(frozen=True, eq=False)
class Attachment:
    """particle i32 (k,): bound particles; pinned bool (k,): held on the body (else only
    their motion-constraint centre follows it); corners i32 (k,3): body point indices (the
    numbering of ColliderArrays.mesh_points); weights f64 (k,3) barycentric; offset f64 (k,)
    along the triangle's unit normal, scene units."""

    particle: np.ndarray
    pinned: np.ndarray
    corners: np.ndarray
    weights: np.ndarray
    offset: np.ndarray

    def positions(self, body_points: np.ndarray) -> np.ndarray:
        """f64 (k,3) attached positions on the body posed as ``body_points``."""
        p = np.asarray(body_points, np.float64)[self.corners]
        normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        return np.einsum("kc,kcx->kx", self.weights, p) + self.offset[:, None] * normal


def closest_points_on_triangles(points: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """(k,t,3) closest point of each of k points on each of t triangles (Ericson, Real-Time
    Collision Detection 5.1.5, vectorised over both)."""
    p = points[:, None, :]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("tx,ktx->kt", ab, ap), np.einsum("tx,ktx->kt", ac, ap)
    bp, cp = p - b, p - c
    d3, d4 = np.einsum("tx,ktx->kt", ab, bp), np.einsum("tx,ktx->kt", ac, bp)
    d5, d6 = np.einsum("tx,ktx->kt", ab, cp), np.einsum("tx,ktx->kt", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = 1.0 / (va + vb + vc)
        v, w = vb * denom, vc * denom
        result = a + ab * v[..., None] + ac * w[..., None]  # inside the face
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    edge_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
    result = np.where(edge_bc[..., None], b + (c - b) * t_bc[..., None], result)
    edge_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    result = np.where(edge_ac[..., None], a + ac * t_ac[..., None], result)
    edge_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    result = np.where(edge_ab[..., None], a + ab * t_ab[..., None], result)
    result = np.where(((d6 >= 0) & (d5 <= d6))[..., None], c + 0 * p, result)
    result = np.where(((d3 >= 0) & (d4 <= d3))[..., None], b + 0 * p, result)
    result = np.where(((d1 <= 0) & (d2 <= 0))[..., None], a + 0 * p, result)
    return result


def bind_attachment(
    rest: np.ndarray, particle: np.ndarray, pinned: np.ndarray, body_points: np.ndarray, triangles: np.ndarray, name: str
) -> Attachment:
    """Bind ``rest[particle]`` to the closest of ``triangles`` of the body at rest (see the
    module docstring)."""
    body = np.asarray(body_points, np.float64)
    tri = np.asarray(triangles, np.int64)
    a, b, c = body[tri[:, 0]], body[tri[:, 1]], body[tri[:, 2]]
    normal = np.cross(b - a, c - a)
    area2 = np.linalg.norm(normal, axis=1)
    usable = area2 > 1e-12 * max(float(area2.max(initial=0.0)), 1e-300)
    if not usable.any():
        raise SceneError(f"cloth '{name}': the body it attaches to has no triangle with an area; check the body mesh")
    tri, a, b, c, normal = tri[usable], a[usable], b[usable], c[usable], normal[usable] / area2[usable, None]
    points = np.asarray(rest, np.float64)[particle]
    chosen = np.empty(points.shape[0], np.int64)
    for first in range(0, points.shape[0], _CHUNK):
        block = points[first:first + _CHUNK]
        closest = closest_points_on_triangles(block, a, b, c)
        chosen[first:first + _CHUNK] = np.argmin(np.sum((closest - block[:, None, :]) ** 2, axis=2), axis=1)
    n = normal[chosen]
    offset = np.einsum("kx,kx->k", points - a[chosen], n)
    projected = points - offset[:, None] * n
    # barycentric coordinates of the projection (outside [0,1] when it falls off the triangle)
    v0, v1, v2 = b[chosen] - a[chosen], c[chosen] - a[chosen], projected - a[chosen]
    d00, d01, d11 = (np.einsum("kx,kx->k", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("kx,kx->k", v2, v0), np.einsum("kx,kx->k", v2, v1)
    denom = d00 * d11 - d01 * d01
    wb, wc = (d11 * d20 - d01 * d21) / denom, (d00 * d21 - d01 * d20) / denom
    weights = np.stack([1.0 - wb - wc, wb, wc], axis=1)
    return Attachment(particle.astype(np.int32), pinned.astype(bool), tri[chosen].astype(np.int32), weights, offset)


class AttachStage(Stage):
    """Moves the bound particles with the body (see the module docstring). The solver's
    ``motion_centers`` (n,3) holds every particle's motion-constraint centre."""

    name = "attach"

    def __init__(self, solver):
        super().__init__(solver)
        attachment = solver.attachment
        real = solver.state.cur.dtype
        self.particle = attachment.particle
        self.pinned = attachment.pinned
        self.start = np.zeros((attachment.particle.shape[0], 3), real)
        self.end = self.start.copy()
        self.alpha_type = real.type

    def begin_frame(self, plan: FramePlan) -> None:
        colliders = self.solver.environment.colliders
        attachment = self.solver.attachment
        self.start[:] = attachment.positions(colliders(plan.time).mesh_points)
        self.end[:] = attachment.positions(colliders(plan.end).mesh_points)
        self.alpha1 = stacked([(i + 1) / plan.iterations for i in range(plan.iterations)], self.alpha_type)

    def warm_up(self) -> None:
        none = self.start[:0]
        attach_particles(self.particle[:0], self.pinned[:0], none, none, self.alpha_type(0.0),
                         self.solver.motion_centers[:0], self.solver.state.cur[:0])

    def run(self, iteration: Iteration) -> None:
        attach_particles(self.particle, self.pinned, self.start, self.end, self.alpha1[iteration.index],
                         self.solver.motion_centers, self.solver.state.cur)

    def fused_call(self) -> FusedCall:
        return FusedCall(
            ("{attach}({particle}, {pinned}, {start}, {end}, {alpha1}[it], {centers}, cur)",),
            {"particle": self.particle, "pinned": self.pinned, "start": self.start, "end": self.end, "alpha1": self.alpha1,
             "centers": self.solver.motion_centers},
            {"attach": attach_particles},
        )
