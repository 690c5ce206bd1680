"""Local-space simulation (solver/frame.py): a cloth that follows a track is simulated in the
track's frame, world = R(t) x + T(t).

* With inertia 1 and drag 0 the frame is a change of coordinates only: a free particle falls
  ballistically in the world however the frame moves, X(t) = X0 + V0 t + g t^2 / 2, and an
  unpinned cloth's centre of mass does the same.
* With inertia 0 the frame's motion does not reach the particles: a free particle's local
  coordinates are those of a particle falling in a frame at rest.
* A teleport moves the frame without the jump becoming motion: the cloth's local state goes
  on exactly as if the track had not jumped.

The tracks below start moving at t = 0 and are linear before (T(t) = T0 + V t, R constant for
t <= 0): the solver starts the cloth moving with its frame from the pose one iteration before
the start, so the frame's velocity at the start is exactly V and the world's initial velocity
is V + v, v being the solver's ``initial_velocity`` (R(0) = I, so v is the same in both axes).
The frame also falls with gravity, plus a wobble, so that the particle's local coordinates stay
within a metre: float32 rounding grows with |x| and the number of steps (see
``rounding_budget``).
"""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.settings import Material, SolverConfig
from clothtool.solver.frame import Pose

EPS32 = float(np.finfo(np.float32).eps)
G = np.array([0.0, -9.81, 0.0])
T0 = np.array([0.3, 1.0, -0.2])
V = np.array([1.0, 0.5, -2.0])  # the frame's velocity at the start
WOBBLE = np.array([0.2, 0.1, -0.15])  # amplitude (m) of the frame's extra acceleration, at 3 rad/s
SPIN = 2.0  # rad/s^2: angle = SPIN t^2 / 2
X0 = np.array([[0.4, 0.1, -0.3]])  # the particle's rest position in the frame
V_START = np.array([0.1, 0.2, -0.1])  # initial_velocity


def rotation(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * k @ k


def falling_spinning_track(axis):
    """Accelerating (gravity plus a wobble) and spinning up about ``axis``; linear before 0."""

    def pose(t: float) -> Pose:
        s = max(t, 0.0)
        translation = T0 + V * t + 0.5 * G * s * s + WOBBLE * (1.0 - np.cos(3.0 * s))
        return Pose(rotation(axis, 0.5 * SPIN * s * s), translation)

    return pose


def rounding_budget(extent: float, steps: int) -> float:
    """Statistical float32 budget for a Verlet-like update over ``steps`` steps on coordinates
    of magnitude <= extent: a few roundings of <= eps*extent/2 per step, each carried on as a
    velocity error and so growing linearly, add up like a random walk to ~eps*extent*N^1.5/3;
    this allows three times that. (A velocity error of a*h/2 from a wrong start, the smallest
    discretisation mistake, is 3e-2 m over 2 s at 300 Hz, with a ~ 10 m/s^2.)"""
    return EPS32 * extent * steps**1.5


def ballistic(x0_world: np.ndarray, t: float) -> np.ndarray:
    return x0_world + (V + V_START) * t + 0.5 * G * t * t


AXES = {"about-Y": (0.0, 1.0, 0.0), "tilted": (1.0, 2.0, 0.5)}


def fall_in_frame(axis, frequency, fps, precision, fabric, solver_for, material=None):
    """Simulate 2 s; returns (solver, per-frame world points (frames, n, 3), largest local
    coordinate seen, steps)."""
    track = falling_spinning_track(axis)
    material = material or Material(areal_density=1.0, damping=0.0)
    config = SolverConfig(frequency=frequency, precision=precision)
    solver = solver_for(fabric, material, config, gravity=G, track=track, initial_velocity=V_START)
    dt = 1.0 / fps
    worlds, extent = [], 0.0
    for frame in range(1, 2 * fps + 1):
        solver.step(frame, (frame - 1) * dt, dt, frame * dt)
        worlds.append(solver.world_points().astype(np.float64))
        extent = max(extent, float(np.abs(solver.state.cur[:, :3]).max()))
    return solver, np.array(worlds), extent, 2 * frequency


@pytest.mark.parametrize("axis", list(AXES), ids=list(AXES))
@pytest.mark.parametrize("frequency, fps", [(60, 60), (120, 24), (300, 60)])
def test_free_particle_in_moving_frame_is_ballistic(axis, frequency, fps, build_fabric, solver_for):
    fabric = build_fabric(X0, [1.0])
    solver, worlds, extent, steps = fall_in_frame(AXES[axis], frequency, fps, "float32", fabric, solver_for)
    start = falling_spinning_track(AXES[axis])(0.0).to_world(fabric.rest_pos.astype(np.float64))[0]
    exact = np.array([ballistic(start, frame / fps) for frame in range(1, 2 * fps + 1)])
    error = np.abs(worlds[:, 0] - exact).max()
    budget = rounding_budget(extent, steps)
    assert error <= budget, (
        f"off the ballistic path by {error:.3g} m within 2 s ({steps} steps); rounding allows {budget:.3g} m"
    )
    # the frame really moved and turned under the particle
    assert np.abs(solver.history.now.translation - T0).max() > 10.0
    assert np.abs(solver.history.now.rotation - np.eye(3)).max() > 0.5


@pytest.mark.parametrize("axis", list(AXES), ids=list(AXES))
@pytest.mark.parametrize("frequency, fps", [(120, 24), (300, 60)])
def test_free_particle_in_moving_frame_is_ballistic_float64(axis, frequency, fps, build_fabric, solver_for):
    """"With i = 1 and d = 0 this is world-space Verlet to rounding" (frame.py): in float64
    state that is ~1e-12 m; allow 1e-6 m."""
    fabric = build_fabric(X0, [1.0])
    _, worlds, _, steps = fall_in_frame(AXES[axis], frequency, fps, "float64", fabric, solver_for)
    start = falling_spinning_track(AXES[axis])(0.0).to_world(fabric.rest_pos.astype(np.float64))[0]
    exact = np.array([ballistic(start, frame / fps) for frame in range(1, 2 * fps + 1)])
    error = np.abs(worlds[:, 0] - exact).max()
    assert error <= 1e-6, f"float64 state: off the ballistic path by {error:.3g} m within 2 s ({steps} steps)"


@pytest.mark.parametrize("frequency, fps", [(120, 24), (300, 60)])
def test_unpinned_cloth_in_moving_frame_falls_ballistically(frequency, fps, grid_fabric, solver_for):
    """Constraints are internal: the centre of mass of a free cloth in a moving, spinning frame
    falls like a particle, and the cloth, which starts with one velocity, stays undeformed."""
    fabric = grid_fabric(5, 5, 0.1, plane="XZ")
    axis = AXES["tilted"]
    material = Material(areal_density=1.0, damping=0.0)
    solver, worlds, extent, steps = fall_in_frame(axis, frequency, fps, "float32", fabric, solver_for, material)
    mass = 1.0 / solver.model.inv_mass.astype(np.float64)
    rest_world = falling_spinning_track(axis)(0.0).to_world(solver.model.rest_pos.astype(np.float64))
    com0 = mass @ rest_world / mass.sum()
    com = np.einsum("i,fij->fj", mass, worlds) / mass.sum()
    exact = np.array([ballistic(com0, frame / fps) for frame in range(1, 2 * fps + 1)])
    budget = rounding_budget(extent + 0.5, steps)
    error = np.abs(com - exact).max()
    assert error <= budget, (
        f"centre of mass off the ballistic path by {error:.3g} m (rounding allows {budget:.3g} m)"
    )
    # rigid translation in the world: each particle keeps its offset from the centre of mass
    offsets = worlds[-1] - com[-1]
    deformation = np.abs(offsets - (rest_world - com0)).max()
    assert deformation <= budget, f"the cloth deformed by {deformation:.3g} m"


@pytest.mark.parametrize("spin", [False, True], ids=["translating", "translating-and-spinning-about-Y"])
@pytest.mark.parametrize("frequency, fps", [(120, 24), (300, 60)])
def test_particle_without_inertia_keeps_its_local_motion(spin, frequency, fps, build_fabric, solver_for):
    """linear_inertia = 0 (and angular_inertia = 0 when the frame spins): the frame's motion does
    not act on the particle, so in local coordinates it falls as in a frame at rest,
    x(t) = x0 + v t + g t^2 / 2 (gravity along the spin axis Y is the same in both frames)."""
    translate = falling_spinning_track((0.0, 1.0, 0.0))

    def track(t: float) -> Pose:
        pose = translate(t)
        return pose if spin else Pose(np.eye(3), pose.translation)

    material = Material(areal_density=1.0, damping=0.0, linear_inertia=0.0, angular_inertia=0.0 if spin else 1.0)
    fabric = build_fabric(X0, [1.0])
    config = SolverConfig(frequency=frequency)
    solver = solver_for(fabric, material, config, gravity=G, track=track, initial_velocity=V_START)
    dt = 1.0 / fps
    worst, extent = 0.0, 0.0
    for frame in range(1, fps + 1):  # 1 s
        solver.step(frame, (frame - 1) * dt, dt, frame * dt)
        t = frame * dt
        local = solver.state.cur[0, :3].astype(np.float64)
        exact = fabric.rest_pos[0].astype(np.float64) + V_START * t + 0.5 * G * t * t
        worst = max(worst, float(np.abs(local - exact).max()))
        extent = max(extent, float(np.abs(local).max()))
        # and in the world it is carried along: world = R x + T
        world = solver.world_points()[0].astype(np.float64)
        pose = track(t)
        assert np.abs(world - pose.to_world(local[None])[0]).max() < 1e-5
    budget = rounding_budget(extent, frequency)
    assert worst <= budget, (
        f"local position off x0 + v t + g t^2/2 by {worst:.3g} m (rounding allows {budget:.3g} m)"
    )
    # the frame's own motion (accelerating, spinning) was large
    assert np.abs(track(1.0).translation - (T0 + V)).max() > 4.0


def teleport_run(frame_count, teleport_frame, moving, jump, build_fabric, solver_for, fps=60, frequency=300):
    """A free particle in a frame that, when ``jump``, jumps by a translation and a turn about Y
    during ``teleport_frame`` (just after t = (F-1)/fps: the pose at frame F-1 is the old one,
    at frame F the new one), listed as a teleport frame. Returns the
    local positions and velocities at the end of each frame."""
    dt = 1.0 / fps
    t_jump = (teleport_frame - 1) * dt
    velocity = np.array([1.0, 0.0, -0.5]) if moving else np.zeros(3)
    turn_rate = 1.0 if moving else 0.0

    def track(t: float) -> Pose:
        jumped = jump and t > t_jump + 1e-9
        angle = turn_rate * t + (0.7 if jumped else 0.0)
        offset = np.array([5.0, -2.0, 3.0]) if jumped else np.zeros(3)
        return Pose(rotation((0.0, 1.0, 0.0), angle), velocity * t + offset)

    fabric = build_fabric(X0, [1.0])
    teleports = frozenset({teleport_frame}) if jump else frozenset()
    solver = solver_for(
        fabric, Material(areal_density=1.0, damping=0.0), SolverConfig(frequency=frequency), gravity=G,
        track=track, teleport_frames=teleports, initial_velocity=(0.2, 0.1, 0.0),
    )
    h = dt / int(frequency / fps)
    positions, velocities = [], []
    for frame in range(1, frame_count + 1):
        solver.step(frame, (frame - 1) * dt, dt, frame * dt)
        cur = solver.state.cur[0, :3].astype(np.float64)
        positions.append(cur)
        velocities.append((cur - solver.state.prev[0, :3]) / h)
    return np.array(positions), np.array(velocities)


# Frames are stepped with their exact end time (as the bake does), so frame F-1's last
# iteration samples the track exactly at (F-1)/fps, before the jump, whatever the rounding of
# (F-2)/fps + 5 h: these frames used to see the jump as motion.
@pytest.mark.parametrize("teleport_frame", [13, 25, 30, 31])
def test_teleport_of_resting_frame_keeps_local_state(teleport_frame, build_fabric, solver_for):
    after = teleport_frame + 10
    ref_pos, ref_vel = teleport_run(after, teleport_frame, False, False, build_fabric, solver_for)
    pos, vel = teleport_run(after, teleport_frame, False, True, build_fabric, solver_for)
    assert np.abs(pos - ref_pos).max() < 1e-5, f"local position changed by {np.abs(pos - ref_pos).max():.3g} m"
    assert np.abs(vel - ref_vel).max() < 1e-3, f"local velocity changed by {np.abs(vel - ref_vel).max():.3g} m/s"


def test_teleport_of_moving_frame_keeps_local_state(build_fabric, solver_for):
    """Frame moving at 1.1 m/s and turning at 1 rad/s before and after the jump (frame 25,
    where the rounding above is favourable)."""
    ref_pos, ref_vel = teleport_run(35, 25, True, False, build_fabric, solver_for)
    pos, vel = teleport_run(35, 25, True, True, build_fabric, solver_for)
    assert np.abs(pos - ref_pos).max() < 1e-5, f"local position changed by {np.abs(pos - ref_pos).max():.3g} m"
    assert np.abs(vel - ref_vel).max() < 1e-3, f"local velocity changed by {np.abs(vel - ref_vel).max():.3g} m/s"
