"""Stage: self-collision and cloth-cloth collision (NvCloth's selfCollideParticles, on a grid).

Particles of this cloth keep the material's ``self_collision_distance`` (metres, converted to
scene units) from each other, except pairs that are closer than that in the rest pose
(NvCloth's rest filter: neighbours at rest are not fought over). With
``SolverConfig.cloth_collision`` the cloth also keeps its particles away from those of its
neighbour cloths (``ClothSolver.neighbours``), read in their current state and moved into
this cloth's frame; only this cloth's particles move, by their share of each pair's
correction (w_i / (w_i + w_j)), and each neighbour's own stage moves its side.

A cloth-cloth pair keeps the *larger* of the two cloths' distances, so that both cloths
agree on the separation they enforce (with its own distance each, the thicker cloth would
keep pushing against a gap the thinner one is content with). A sleeping neighbour's
particles count as immovable, so this cloth takes the whole correction.

Stiffness: ``self_collision_stiffness`` per stiffness-frequency step, converted to the
iteration length in log space like every NvCloth stiffness. The kernels are described in
``clothtool.solver.kernels.selfcollide``: the pairs come from a neighbour list that is
rebuilt only when the points have moved more than about half its skin. All buffers are
allocated here; the list's grows between frames when a rebuild found it too small (until
then the kernel works through it in chunks, with the same result).
"""

from __future__ import annotations

import numpy as np

from clothtool.solver.framefn import FusedCall, copy_lines
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.selfcollide import collide_points, collide_points_parallel, transform_points
from clothtool.solver.logstiffness import iteration_stiffness
from clothtool.solver.stage import Stage

_EYE = np.eye(3, dtype=np.float32)
_ZERO = np.zeros(3, np.float32)
# the list's skin, as a fraction of the largest distance: a wider skin lists more pairs (read
# at every iteration) and makes the grid's cells larger, a narrower one rebuilds the list more
# often. 0.3 was the cheapest of 0.1 / 0.2 / 0.3 / 0.5 on benchmarks/nvcloth_table.py's
# self-collision sheets (64^2 and 128^2, distance 3/4 of the spacing)
SKIN_FRACTION = 0.3
# first capacity of the list, in entries per point: a hanging sheet lists under one, a sheet
# folded onto itself a few; the buffer grows between frames when a build needs more
PAIRS_PER_POINT = 4


def pair_distances(solver) -> list[float]:
    """Scene units: the distance kept from this cloth's own particles (0 when self-collision
    is off), then from each neighbour's particles (0 when cloth-cloth collision is off)."""
    material = solver.model.material
    to_scene = 1.0 / solver.model.units_to_meters
    own = material.self_collision_distance
    distances = [own * to_scene if solver.config.self_collision else 0.0]
    for neighbour in solver.neighbours if solver.config.cloth_collision else ():
        distances.append(max(own, neighbour.model.material.self_collision_distance) * to_scene)
    return distances


def needs_self_collide(solver) -> bool:
    """Whether the cloth has anything to collide its particles with."""
    return solver.model.material.self_collision_stiffness > 0 and max(pair_distances(solver)) > 0


def _pose(solver):
    return None if solver.history is None else solver.history.now


class SelfCollideStage(Stage):
    name = "self-collide"

    def __init__(self, solver):
        super().__init__(solver)
        distances = pair_distances(solver)
        self.neighbours = list(solver.neighbours) if len(distances) > 1 else []
        sizes = [solver.model.particle_count] + [n.model.particle_count for n in self.neighbours]
        ends = np.cumsum(sizes)
        total = int(ends[-1])
        self.own = sizes[0]
        self.spans = [(int(ends[k]), int(ends[k + 1])) for k in range(len(self.neighbours))]
        self.segment_distance = np.asarray(distances, np.float32)
        self.point_segment = np.repeat(np.arange(len(sizes), dtype=np.int32), sizes)
        largest = max(distances)
        self.skin = np.float32(SKIN_FRACTION * largest)
        self.inv_cell = np.float32(1.0 / (largest + float(self.skin)))  # cells as large as the list's reach
        dtype = solver.state.cur.dtype
        self.points = np.zeros((total, 4), dtype)
        self.anchor = np.zeros((total, 4), dtype)
        self.sorted_points = np.zeros((total, 4), dtype)
        self.sorted_cell = np.zeros((total, 3), np.int32)
        buckets = 1 << max(1, int(2 * total - 1).bit_length())  # a power of two >= 2 * total
        self.bucket_start = np.zeros(buckets + 1, np.int32)
        self.order = np.zeros(total, np.int32)
        self.strides = np.zeros(2, np.int64)  # the grid's row and layer lengths, set at each build
        self.row_start = np.zeros(self.own + 1, np.int32)
        self.row_split = np.zeros(self.own, np.int32)
        self.pairs = np.zeros(max(PAIRS_PER_POINT * total, 1), np.int32)  # >= one entry per point
        self.found = np.zeros((self.pairs.shape[0], 2), np.int32)  # the pairs a build found, once each
        self.list_state = np.zeros(2, np.int64)  # [list complete, entries needed]: none yet
        self.sums = np.zeros((self.own, 4), dtype)
        # all cores from parallel_threshold points, like the fabric's sets: a parallel kernel
        # is faster on an idle multi-core machine but waits for every thread, which costs
        # whole scheduler slices when other jobs share the cores. Same bits either way.
        parallel = total >= solver.config.parallel_threshold
        self.kernel = collide_points_parallel if parallel else collide_points
        self.stiffness = np.float32(0.0)

    @property
    def fused(self) -> bool:
        """Without neighbours: with them, the cloths' iterations interleave in Python."""
        return not self.neighbours

    def begin_frame(self, plan: FramePlan) -> None:
        solver = self.solver
        k = solver.model.material.self_collision_stiffness
        self.stiffness = iteration_stiffness(k, solver.config.stiffness_frequency, plan.h)
        needed = int(self.list_state[1])
        if needed > self.pairs.shape[0]:  # the last build did not fit: room for it and some more
            self.pairs = np.zeros(needed + needed // 2, np.int32)
            self.found = np.zeros((self.pairs.shape[0], 2), np.int32)

    def warm_up(self) -> None:
        solver = self.solver
        points = self.points[:0]
        transform_points(solver.state.cur[:0], _EYE, _ZERO, np.float32(1.0), points)
        for neighbour in self.neighbours:  # their state may be of another precision
            transform_points(neighbour.state.cur[:0], _EYE, _ZERO, np.float32(1.0), points)
        self.kernel(*self._arguments(points, self.anchor[:0], self.row_start[:1], solver.state.cur[:0]))
        self.list_state[:] = 0  # the empty call's "list" is no list of the cloth's

    def _arguments(self, points, anchor, row_start, cur) -> tuple:
        return (
            points, anchor, self.skin, self.inv_cell, self.bucket_start, self.order, self.sorted_points,
            self.sorted_cell, self.strides, self.solver.model.rest_pos, self.point_segment, self.segment_distance, self.stiffness,
            row_start, self.row_split, self.pairs, self.found, self.list_state, self.sums, cur,
        )

    def _relative_pose(self, neighbour) -> tuple[np.ndarray, np.ndarray]:
        """(matrix, offset) taking the neighbour's frame coordinates into this cloth's."""
        mine, theirs = _pose(self.solver), _pose(neighbour)
        if mine is None and theirs is None:
            return _EYE, _ZERO
        r_a, t_a = (np.eye(3), np.zeros(3)) if mine is None else (mine.rotation, mine.translation)
        r_b, t_b = (np.eye(3), np.zeros(3)) if theirs is None else (theirs.rotation, theirs.translation)
        matrix = np.ascontiguousarray(r_a.T @ r_b, np.float32)
        offset = (r_a.T @ (t_b - t_a)).astype(np.float32)
        return matrix, offset

    def gather(self) -> None:
        """Snapshot this cloth's particles and its neighbours' (in this cloth's frame)."""
        self.points[: self.own] = self.solver.state.cur
        for neighbour, (start, end) in zip(self.neighbours, self.spans):
            matrix, offset = self._relative_pose(neighbour)
            w_scale = np.float32(0.0 if neighbour.sleep.asleep else 1.0)
            transform_points(neighbour.state.cur, matrix, offset, w_scale, self.points[start:end])

    def run(self, iteration: Iteration) -> None:
        self.gather()
        self.kernel(*self._arguments(self.points, self.anchor, self.row_start, self.solver.state.cur))

    def fused_call(self) -> FusedCall:
        # gather() without neighbours: the snapshot is a copy of the cloth's own particles
        names = ("points", "anchor", "skin", "inv_cell", "bucket_start", "order", "sorted_points", "sorted_cell",
                 "strides", "rest_pos", "point_segment", "segment_distance", "stiffness", "row_start", "row_split", "pairs",
                 "found", "list_state", "sums")
        values = self._arguments(self.points, self.anchor, self.row_start, None)[:-1]
        return FusedCall(
            (*copy_lines("cur", "{points}"),
             "{collide}(" + ", ".join("{%s}" % name for name in names) + ", cur)"),
            dict(zip(names, values)),
            {"collide": self.kernel},
        )
