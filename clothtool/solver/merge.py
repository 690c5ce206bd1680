"""Many cloths of a scene solved as one: position-based cloths that can share a solve run
as one merged cloth, one compiled frame call per frame instead of one per cloth.

Cloths share no particle, so a scene's cloths are the disjoint union of their particles: the
merged model concatenates particles, triangles and tethers (indices offset) and lists, phase
by phase, every member's conflict-free constraint sets whole (and the wind stage's triangle
colours likewise): each set is solved exactly as when its cloth is solved alone, in the same
blocks, so every per-particle, per-constraint and per-triangle computation gives the same
bits (``_merged_sets`` says why sets are not fused across cloths). The cost per particle
iteration is then that of the members' own sets, without a compiled call, a frame plan and
a frame function's argument list per cloth.

What is global over a cloth cannot be merged that way, so such cloths are not grouped
(``merge_key`` returns None): a free cloth (damped relative to its own mean motion), a cloth
on a track or attached to a body, sleep (a per-cloth stillness test), self- and cloth-cloth
collision (a merged cloth would collide with the others), and colliders (the collide stage
builds per-cloth face lists and virtual particles). Cloths group only when every scalar
the kernels take is the same: the material, the motion settings, the stages, the phases,
the initial velocity, the units, and for tethers the particle and tether counts (the tether
stiffness is scaled by their ratio).

Each cloth keeps its own solver object (a ``GroupMember``): its state arrays are views into
the merged state, so the per-cloth stats, stability checks, report and cache writing see
exactly what they see today, in the same order; only the first member of a group runs the
merged solve.
"""

from __future__ import annotations

import dataclasses
from typing import cast

import numpy as np

from clothtool.fabric import Fabric
from clothtool.solver.cloth import ClothSolver
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.model import ClothModel
from clothtool.solver.tethers import TetherStage


@dataclasses.dataclass(frozen=True)
class MergedFabric:
    """What the stages read from a merged model's fabric: the particles' lumped areas (the
    xpbd compliance). Everything else a fabric holds stays with each cloth's own model."""

    particle_area: np.ndarray
    vertex_particle: None = None  # a merged cloth writes no cache rows (its members do, in their own order)


def merge_key(solver) -> tuple | None:
    """What must be equal for two cloths to share one solve, or None when the cloth must be
    solved on its own (module docstring)."""
    if type(solver) is not ClothSolver:
        return None
    config, model, environment = solver.config, solver.model, solver.environment
    if config.self_collision or config.cloth_collision or config.sleep_threshold > 0 or solver.neighbours:
        return None
    if environment.colliders is not None or solver.track is not None or solver.attachment is not None:
        return None
    integrate = solver.stages[0]
    if getattr(integrate, "free", True):
        return None
    names = tuple(solver.stage_names)
    tethers = (model.particle_count, int(model.tether_anchor.shape[0])) if "tethers" in names else None
    return (
        names, model.material, model.motion, model.phase_labels, model.units_to_meters, tethers,
        model.backstop_centers is None, tuple(solver.initial_velocity.tolist()), solver.state.cur.dtype.str,
    )


def _merged_sets(models: list[ClothModel]):
    """(order, set_offsets, phase_set_offsets) of the union: ``order`` lists the members'
    constraints (numbered as concatenated in member order) in their merged order. Phase p of
    the union holds every member's sets of phase p, member after member, each set whole: the
    fabric kernel measures a set's constraints four at a time from the set's start and its
    last few one by one, and fused multiply-adds round those two paths differently, so a
    constraint keeps its bits only at its own place in its own set (merging set j of every
    member into one set changed the last bits of some)."""
    first = np.cumsum([0] + [m.constraint_indices.shape[0] for m in models])
    chunks, set_offsets, phase_set_offsets, size = [], [0], [0], 0
    for p in range(len(models[0].phase_labels)):
        for k, m in enumerate(models):
            for s in range(int(m.phase_set_offsets[p]), int(m.phase_set_offsets[p + 1])):
                chunk = first[k] + np.arange(m.set_offsets[s], m.set_offsets[s + 1])
                chunks.append(chunk)
                size += chunk.size
                set_offsets.append(size)
        phase_set_offsets.append(len(set_offsets) - 1)
    order = np.concatenate(chunks) if chunks else np.zeros(0, np.int64)
    return order, np.asarray(set_offsets, np.int32), np.asarray(phase_set_offsets, np.int32)


def _merged_tethers(models: list[ClothModel], offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Tether anchors and rest lengths of the union in the kernel's layout (slot s of
    particle i at s * n + i): every member has the same number of slots (merge_key)."""
    slots = models[0].tether_anchor.shape[0] // max(models[0].particle_count, 1)
    anchors, lengths = [], []
    for s in range(slots):
        for k, m in enumerate(models):
            n = m.particle_count
            anchors.append(m.tether_anchor[s * n:(s + 1) * n] + offsets[k])
            lengths.append(m.tether_rest_length[s * n:(s + 1) * n])
    return np.concatenate(anchors).astype(np.int32), np.concatenate(lengths).astype(np.float32)


def merged_model(models: list[ClothModel]) -> ClothModel:
    """The disjoint union of ``models`` (which share material, phases and settings)."""
    counts = [m.particle_count for m in models]
    offsets = np.cumsum([0] + counts)[:-1]
    order, set_offsets, phase_set_offsets = _merged_sets(models)
    indices = np.concatenate([m.constraint_indices + offsets[k] for k, m in enumerate(models)])
    tether_anchor, tether_rest_length = _merged_tethers(models, offsets)
    backstop = models[0].backstop_centers is not None
    first = models[0]
    return ClothModel(
        name="+".join(m.name for m in models),
        # the group's stages read only the areas; each cloth's own model keeps its fabric
        fabric=cast(Fabric, MergedFabric(np.concatenate([m.fabric.particle_area for m in models]))),
        material=first.material,
        rest_pos=np.concatenate([m.rest_pos for m in models]),
        inv_mass=np.concatenate([m.inv_mass for m in models]),
        mass=np.concatenate([m.mass for m in models]),
        triangles=np.concatenate([m.triangles + offsets[k] for k, m in enumerate(models)]).astype(np.int32),
        constraint_indices=np.ascontiguousarray(indices[order], np.int32),
        constraint_rest_length=np.concatenate([m.constraint_rest_length for m in models])[order],
        constraint_stiffness=np.concatenate([m.constraint_stiffness for m in models])[order],
        set_offsets=set_offsets,
        phase_set_offsets=phase_set_offsets,
        phase_labels=first.phase_labels,
        tether_anchor=tether_anchor,
        tether_rest_length=tether_rest_length,
        max_distance=np.concatenate([m.max_distance for m in models]),
        motion=first.motion,
        backstop_centers=np.concatenate([m.backstop_centers for m in models]) if backstop else None,
        backstop_radii=np.concatenate([m.backstop_radii for m in models]) if backstop else None,
        units_to_meters=first.units_to_meters,
        length_scale=first.length_scale,
    )


class GroupSolver(ClothSolver):
    """The merged solve of a group of cloths (module docstring). Built from the members'
    own solvers: the scalars a stage derives from a whole cloth are taken from the first
    member's stage (equal in every member, merge_key), and the wind's triangle colours and
    shares are the members', so that each cloth gets exactly its own numbers."""

    def __init__(self, members: list[ClothSolver]):
        first = members[0]
        super().__init__(
            merged_model([m.model for m in members]), first.config, first.environment, first.profiler,
            initial_velocity=first.initial_velocity,
        )
        self.members = members
        self.current_plan: FramePlan | None = None  # this frame's plan (GroupMember.plan_frame)
        self._first_stages = {stage.name: stage for stage in first.stages}
        self.offsets = np.cumsum([0] + [m.model.particle_count for m in members])
        for stage in self.stages:
            if stage.name == "wind" and stage.name in first.stage_names:
                wind = first.stage_names.index("wind")
                self._merge_wind(stage, [m.stages[wind] for m in members], self.offsets)

    def bind_members(self) -> None:
        """Make each member's state its rows of the merged state (which starts as theirs)."""
        for k, member in enumerate(self.members):
            rows = slice(int(self.offsets[k]), int(self.offsets[k + 1]))
            member.state = dataclasses.replace(member.state, cur=self.state.cur[rows], prev=self.state.prev[rows])

    @staticmethod
    def _merge_wind(stage, member_stages, offsets) -> None:
        """The members' triangle colours one after the other, each member's as scheduled for
        it alone (the same blocks, so the same bits; members share no particle)."""
        triangles, color_offsets = [], [0]
        for k, s in enumerate(member_stages):
            for c in range(s.color_offsets.shape[0] - 1):
                triangles.append(s.triangles[s.color_offsets[c]:s.color_offsets[c + 1]] + offsets[k])
                color_offsets.append(color_offsets[-1] + triangles[-1].shape[0])
        stage.triangles = np.ascontiguousarray(np.concatenate(triangles), np.int32)
        stage.color_offsets = np.asarray(color_offsets, member_stages[0].color_offsets.dtype)
        stage.share = np.concatenate([s.share for s in member_stages])

    def plan_frame(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        plan = super().plan_frame(frame, time, frame_dt, end_time)
        tethers = self._first_stages.get("tethers")
        if tethers is not None:  # NvCloth scales the stiffness by the cloth's particles per tether
            tethers.begin_frame(plan)
            merged = self.stages[self.stage_names.index("tethers")]
            assert isinstance(merged, TetherStage) and isinstance(tethers, TetherStage)
            merged.stiffness, merged.scale = tethers.stiffness, tethers.scale
        return plan


class GroupMember:
    """One cloth of a merged group, as the bake sees it: its own model, state (rows of the
    merged state), stats and output; planning and solving go to the group, done once per
    frame by the first member."""

    def __init__(self, solver: ClothSolver, group: GroupSolver, index: int):
        self.solver = solver
        self.group = group
        self.index = index
        self.model = solver.model
        self.stage_names = solver.stage_names

    @property
    def leader(self) -> bool:
        return self.index == 0

    # what the stats and the writer read
    @property
    def state(self):
        return self.solver.state

    @property
    def environment(self):
        return self.solver.environment

    @property
    def config(self):
        return self.solver.config

    @property
    def asleep(self) -> bool:
        return self.group.asleep

    def set_neighbours(self, neighbours) -> None:
        """Never called: cloths that collide with each other are not merged (merge_key)."""
        raise RuntimeError("merged cloths do not collide with other cloths")

    def warm_up(self) -> None:
        if self.leader:
            self.group.warm_up()
        self.solver.warm_up()  # the stats and the writer's kernels, for this cloth's arrays

    def plan_frame(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        """The group's plan of the frame: planned by the first member, which the bake asks first."""
        if self.leader:
            self.group.current_plan = self.group.plan_frame(frame, time, frame_dt, end_time)
        assert self.group.current_plan is not None, "the group's first cloth plans the frame"
        return self.group.current_plan

    def iteration(self, plan: FramePlan, index: int) -> Iteration:
        if self.leader:
            return self.group.iteration(plan, index)
        return Iteration(index, index / plan.iterations, (index + 1) / plan.iterations, 1.0, None)

    def iterate(self, iteration: Iteration) -> None:
        if self.leader:
            self.group.iterate(iteration)

    def run_frame(self, plan: FramePlan) -> bool:
        if self.leader:
            return self.group.run_frame(plan)
        return True  # the leader's call ran (or its iterations run) this cloth's frame

    def step(self, frame: int, time: float, frame_dt: float, end_time: float | None = None) -> FramePlan:
        plan = self.plan_frame(frame, time, frame_dt, end_time)
        for index in range(plan.iterations):
            self.iterate(self.iteration(plan, index))
        return plan

    def frame_stats(self) -> dict:
        return self.solver.frame_stats()

    def cloth_report(self) -> dict:
        return self.solver.cloth_report()

    def world_points(self) -> np.ndarray:
        return self.solver.world_points()

    def world_velocities(self, h: float) -> np.ndarray:
        return self.solver.world_velocities(h)

    def cache_rows(self, h: float | None) -> tuple[np.ndarray, np.ndarray | None]:
        return self.solver.cache_rows(h)


def merge_solvers(solvers: list) -> list:
    """``solvers`` with every group of two or more cloths that can share a solve replaced by
    GroupMembers of one GroupSolver, in the same order (the first of a group leads it)."""
    groups: dict[tuple, list[int]] = {}
    for index, solver in enumerate(solvers):
        key = merge_key(solver)
        if key is not None:
            groups.setdefault(key, []).append(index)
    merged = list(solvers)
    for indices in groups.values():
        if len(indices) < 2:
            continue
        members = [solvers[i] for i in indices]
        group = GroupSolver(members)
        if group.stage_names != members[0].stage_names:  # a stage the union would add or lose
            continue
        group.bind_members()
        for position, i in enumerate(indices):
            merged[i] = GroupMember(solvers[i], group, position)
    return merged
