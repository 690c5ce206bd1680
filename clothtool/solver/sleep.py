"""Sleeping (NvCloth's updateSleepState): a cloth that stays still stops being simulated.

Every ``sleep_test_interval`` seconds of simulated time (iteration lengths accumulate; the
test runs in the iteration that completes an interval) the "sleep" stage measures the
largest particle displacement over that iteration, |cur - prev|. Below
``sleep_threshold * h`` (m/s times the iteration length, converted to scene units) the test
passes and the pass counter grows; otherwise the counter resets. After
``sleep_after_count`` passes in a row the cloth falls asleep: prev is set to cur (zero
velocity) and the ClothSolver runs no stage at all until it wakes.

A cloth is woken (and its pass counter reset, NvCloth's wakeUp) at the start of a frame in
which something may move it: its track moves or teleports, a collider moves (the scene's
colliders differ between the frame's start and end), the wind changes, or, with cloth-cloth
collision, a moving neighbour cloth comes within reach of it. All but the last also reset
the counter of an awake cloth, so it cannot fall asleep while it is being driven.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from clothtool.solver.framefn import FusedCall, copy_lines
from clothtool.solver.iteration import FramePlan, Iteration
from clothtool.solver.kernels.sleep import max_displacement
from clothtool.solver.stage import Stage

if TYPE_CHECKING:  # pragma: no cover
    from clothtool.solver.cloth import ClothSolver

# relative slack when comparing the accumulated time with the test interval, so that 30
# iterations of 1/300 s make one 0.1 s interval despite rounding
_CLOCK_SLACK = 1e-9


@dataclasses.dataclass
class SleepState:
    """asleep: no stage runs; passes: sleep tests passed in a row; clock: seconds since the
    last test; moving: the last test failed (the cloth can wake sleeping neighbours);
    woken_by: why the cloth last woke (for reports and tests)."""

    asleep: bool = False
    passes: int = 0
    clock: float = 0.0
    moving: bool = True
    woken_by: str | None = None

    def fall_asleep(self, solver: "ClothSolver") -> None:
        self.asleep = True
        state = solver.state
        state.prev[:, :3] = state.cur[:, :3]

    def wake(self, reason: str) -> None:
        self.asleep = False
        self.passes = 0
        self.woken_by = reason

    def begin_frame(self, solver: "ClothSolver", plan: FramePlan) -> None:
        """Wake ``solver`` (or restart its count) when something may move it this frame."""
        if not solver.config.sleep_threshold > 0:
            return
        reason = driven_by(solver, plan)
        if reason is None and self.asleep:
            reason = moving_neighbour(solver)
        if reason is not None:
            self.wake(reason)


def _differs(a, b) -> bool:
    if dataclasses.is_dataclass(a):
        return any(_differs(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a) if f.compare)
    a, b = np.asarray(a), np.asarray(b)
    # NaN stands for "not given" in collider arrays (friction): equal to itself here, or a
    # scene with such a collider would count as moving every frame and never sleep
    return not np.array_equal(a, b, equal_nan=a.dtype.kind in "fc" and b.dtype.kind in "fc")


def _collider_sampler(environment):
    colliders = getattr(environment, "colliders", None)
    if colliders is None:
        return None
    return getattr(colliders, "at", colliders if callable(colliders) else None)


def driven_by(solver: "ClothSolver", plan: FramePlan) -> str | None:
    """Why the cloth may be moved from outside during the frame ``plan``, or None."""
    t0, t1 = plan.time, plan.end
    if solver.track is not None:
        if plan.frame in solver.teleport_frames:
            return "track"
        a, b = solver.track(t0), solver.track(t1)
        if _differs(a.rotation, b.rotation) or _differs(a.translation, b.translation):
            return "track"
    sample = _collider_sampler(solver.environment)
    if sample is not None and _differs(sample(t0), sample(t1)):
        return "colliders"
    environment = solver.environment
    if environment.wind is not None and _differs(environment.wind_at(t0), environment.wind_at(t1)):
        return "wind"
    return None


def _world_bounds(solver: "ClothSolver") -> tuple[np.ndarray, np.ndarray]:
    points = solver.world_points()
    return points.min(axis=0), points.max(axis=0)


def moving_neighbour(solver: "ClothSolver") -> str | None:
    """'neighbour' when an awake, moving neighbour cloth's bounds come within the collision
    distance of this cloth's bounds (world space)."""
    movers = [n for n in solver.neighbours if not n.sleep.asleep and n.sleep.moving and n.model.particle_count]
    if not movers or not solver.model.particle_count:
        return None
    lo, hi = _world_bounds(solver)
    for other in movers:
        reach = max(solver.model.material.self_collision_distance, other.model.material.self_collision_distance)
        reach /= solver.model.units_to_meters
        other_lo, other_hi = _world_bounds(other)
        if np.all(other_lo <= hi + reach) and np.all(lo <= other_hi + reach):
            return "neighbour"
    return None


class SleepStage(Stage):
    """The last stage: the periodic stillness test (see the module docstring)."""

    name = "sleep"

    def begin_frame(self, plan: FramePlan) -> None:
        config = self.solver.config
        self.h = plan.h
        self.threshold = config.sleep_threshold * plan.h / self.solver.model.units_to_meters
        self.interval = config.sleep_test_interval * (1.0 - _CLOCK_SLACK)

    def warm_up(self) -> None:
        state = self.solver.state
        max_displacement(state.cur[:0], state.prev[:0])

    def run(self, iteration: Iteration) -> None:
        solver = self.solver
        sleep = solver.sleep
        sleep.clock += self.h
        if sleep.clock < self.interval:
            return
        sleep.clock -= solver.config.sleep_test_interval
        state = solver.state
        if max_displacement(state.cur, state.prev) < self.threshold:
            sleep.passes += 1
            sleep.moving = False
        else:
            sleep.passes = 0
            sleep.moving = True
        if sleep.passes >= solver.config.sleep_after_count:
            sleep.fall_asleep(solver)

    # The compiled frame function keeps the counters in ``counters`` (clock, passes, moving,
    # asleep), does ``run``'s arithmetic on them and returns when the cloth falls asleep.
    _FUSED_LINES = (
        "{counters}[0] += {h}",
        "if {counters}[0] >= {interval}:",
        "    {counters}[0] -= {test_interval}",
        "    if {displacement}(cur, prev) < {threshold}:",
        "        {counters}[1] += 1.0",
        "        {counters}[2] = 0.0",
        "    else:",
        "        {counters}[1] = 0.0",
        "        {counters}[2] = 1.0",
        "    if {counters}[1] >= {after_count}:",
        "        {counters}[3] = 1.0",
        *("        " + line for line in copy_lines("cur", "prev", "3")),
        "        return it + 1",
    )

    def fused_call(self) -> FusedCall:
        sleep, config = self.solver.sleep, self.solver.config
        self.counters = np.array([sleep.clock, sleep.passes, float(sleep.moving), 0.0])
        return FusedCall(
            self._FUSED_LINES,
            {"counters": self.counters, "h": float(self.h), "interval": float(self.interval),
             "test_interval": float(config.sleep_test_interval), "threshold": float(self.threshold),
             "after_count": float(config.sleep_after_count)},
            {"displacement": max_displacement},
        )

    def end_fused_frame(self) -> None:
        sleep = self.solver.sleep
        clock, passes, moving, asleep = self.counters
        sleep.clock, sleep.passes, sleep.moving = float(clock), int(passes), bool(moving)
        if asleep:
            sleep.asleep = True  # the frame function already set prev to cur
