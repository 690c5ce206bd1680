"""Local-space simulation: Verlet in a moving reference frame, with inertia and drag.

A cloth that follows a track (a cape on a running character) is simulated in the track's
frame: world = R(t) x + T(t). Let n-1, n, n+1 be the ends of the last two iterations and
the current one, c_n(x) = P_n(x) - P_{n-1}(x) the frame's motion of a fixed local point over
the last iteration and c_{n+1} over this one. World-space Verlet, rewritten in local
coordinates, is exactly

    x' = x + R_{n+1}^T R_{n-1} (x - x_prev) + R_{n+1}^T (c_n(x) - c_{n+1}(x)) + R_{n+1}^T g h^2

Damping (velocity scale s) acts on the velocity relative to the frame, as in NvCloth: the
air moves with the character, and the frame's own velocity is shed only through drag. We
also scale the frame terms: inertia i (1 = physical, 0 = particles follow the frame rigidly)
multiplies the frame's acceleration term, and drag d removes the fraction d of the frame's
velocity from the particles (NvCloth's semantics), separately for the linear part (the
translation) and the angular part (the rotation):

    x' = x + s Q (x - x_prev) + K x + b
    Q = i_a R_{n+1}^T R_{n-1} + (1 - i_a) I
    K = R_{n+1}^T [ i_a (D_n - D_{n+1}) - d_a D_{n+1} ]           D_n = R_n - R_{n-1}
    b = R_{n+1}^T [ i_l (dT_n - dT_{n+1}) - d_l dT_{n+1} + g h^2 ]   dT_n = T_n - T_{n-1}

With i = 1, d = 0 and no damping this is world-space Verlet to rounding. Drag values are per
stiffness-frequency step and converted in log space like damping.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any, Callable

import numpy as np

from clothtool.solver.logstiffness import damping_scale

IDENTITY = np.eye(3)


@dataclasses.dataclass
class Pose:
    rotation: np.ndarray  # (3,3) float64, local -> world
    translation: np.ndarray  # (3,) float64

    @classmethod
    def identity(cls) -> "Pose":
        return cls(IDENTITY.copy(), np.zeros(3))

    def to_world(self, points: np.ndarray) -> np.ndarray:
        return points @ self.rotation.T + self.translation

    def to_local(self, points: np.ndarray) -> np.ndarray:
        return (points - self.translation) @ self.rotation


class PoseRows(Sequence):
    """Poses sampled together: the rows of stacked (n,3,3) ``rotations`` and (n,3)
    ``translations``. A row's Pose is made when first asked for and then kept, the same
    object each time (callers tell poses apart by identity): a bake plans hundreds of
    iteration ends at once, but its frames ask for two poses each (~0.4 ms a bake to make
    them all up front). ``known``: rows' Pose objects that exist already. A slice is a
    PoseRows of the same Poses (made or not yet)."""

    def __init__(self, rotations: np.ndarray, translations: np.ndarray, known: dict[int, Pose] | None = None):
        self.rotations = rotations
        self.translations = translations
        self._poses: list[Pose | None] = [None] * rotations.shape[0]  # shared by slices
        self._start = 0  # this one's first row in _poses
        for row, pose in (known or {}).items():
            self._poses[row] = pose

    @classmethod
    def of(cls, poses) -> "PoseRows":
        """The PoseRows of ``poses`` (a PoseRows, or Pose objects, which it keeps)."""
        if isinstance(poses, PoseRows):
            return poses
        poses = list(poses)
        if not poses:
            return cls(np.zeros((0, 3, 3)), np.zeros((0, 3)))
        return cls(np.stack([p.rotation for p in poses]), np.stack([p.translation for p in poses]), dict(enumerate(poses)))

    def __len__(self) -> int:
        return self.rotations.shape[0]

    def __iter__(self):
        # Sequence's own __iter__ asks for rows until IndexError: an exception per loop
        return map(self.__getitem__, range(len(self)))

    def __getitem__(self, index):
        if isinstance(index, slice):
            start, stop, step = index.indices(len(self))
            if step != 1:
                return [self[i] for i in range(start, stop, step)]
            rows = PoseRows.__new__(PoseRows)
            rows.rotations, rows.translations = self.rotations[start:stop], self.translations[start:stop]
            rows._poses, rows._start = self._poses, self._start + start
            return rows
        if index < 0:
            index += len(self)
        if not 0 <= index < len(self):
            raise IndexError("pose row out of range")
        pose = self._poses[self._start + index]
        if pose is None:
            pose = self._poses[self._start + index] = Pose(self.rotations[index], self.translations[index])
        return pose

    def known(self) -> dict[int, Pose]:
        """The rows whose Pose objects exist, by row."""
        rows = self._poses[self._start : self._start + len(self)]
        return {row: pose for row, pose in enumerate(rows) if pose is not None}


# Planned times sampled together: a long bake's poses are not all held at once.
PLANNED_CHUNK = 1024


class FramePath:
    """A moving frame over time: ``path(time)`` is its Pose, ``path.poses(times)`` the poses
    at many times at once (a frame's iteration ends are sampled together: one vectorised
    call instead of one per iteration). ``many`` (times -> list of Poses) is optional.

    ``planned``: the times the path will be asked for (a bake's iteration ends, in order),
    sampled PLANNED_CHUNK at a time in one call each and then looked up, the same Pose
    object for a time as long as it is held; any other time is sampled when asked. ``many``
    must give a time the same pose whatever times go with it."""

    def __init__(
        self,
        at: Callable[[float], Pose],
        many: Callable[[np.ndarray], list[Pose]] | None = None,
        planned=(),
    ):
        self._at = at
        self._many = many
        self._planned = np.unique(np.asarray(planned, np.float64))  # sorted
        self._start = 0  # the index in _planned of the first held pose
        self._held = PoseRows.of([])  # the poses of _planned[_start:_start + len(_held)]
        self._row: dict[float, int] = {}  # time -> its pose's row in _held

    def __call__(self, time: float) -> Pose:
        row = self._hold(time, 1)
        return self._held[row] if row is not None else self._at(time)

    def poses(self, times) -> list[Pose]:
        if len(times) and self._hold(times[0], len(times)) is not None:
            rows = list(map(self._row.get, times))
            if None not in rows:
                return list(map(self._held.__getitem__, rows))  # type: ignore[arg-type]
        return self._sample(times)

    def following(self, time: float, count: int) -> list[Pose]:
        """Up to ``count`` planned poses from the one at ``time`` on (fewer at the end of the
        planned times), the objects ``poses`` gives; [] when ``time`` is not planned."""
        return list(self.following_rows(time, count)[0])

    def following_rows(self, time: float, count: int) -> tuple[PoseRows, list[float]]:
        """``following(time, count)`` as PoseRows (its poses made when asked for: the same
        objects as ``poses`` gives), and their times; empty when ``time`` is not planned."""
        row = self._hold(time, count)
        if row is None:
            return PoseRows.of([]), []
        first = self._start + row
        rows = self._held[row : row + count]
        return rows, self._planned[first : first + len(rows)].tolist()

    def _sample(self, times) -> list[Pose]:
        if self._many is not None:
            return self._many(np.asarray(times, np.float64))
        return [self._at(float(t)) for t in times]

    def _hold(self, time: float, count: int) -> int | None:
        """The row of ``time``'s pose in ``_held`` with up to ``count`` planned poses from it
        held (sampling the next ones, keeping those already held); None: not planned."""
        row = self._row.get(time)
        planned = self._planned
        if row is not None:
            if row + count <= len(self._held) or self._start + len(self._held) >= planned.shape[0]:
                return row  # enough held, or nothing more planned
            first = self._start + row
        else:
            first = int(np.searchsorted(planned, time))
            if first >= planned.shape[0] or planned[first] != time:
                return None
        end = min(first + max(PLANNED_CHUNK, count), planned.shape[0])
        kept = self._held[row:] if row is not None else PoseRows.of([])
        sampled = PoseRows.of(self._sample(planned[first + len(kept) : end]))
        if len(kept) == 0:
            self._held = sampled
        else:  # the poses already made stay the same objects
            known = kept.known()
            known.update({len(kept) + r: pose for r, pose in sampled.known().items()})
            self._held = PoseRows(np.concatenate([kept.rotations, sampled.rotations]),
                                  np.concatenate([kept.translations, sampled.translations]), known)
        self._start = first
        self._row = dict(zip(planned[first:end].tolist(), range(end - first)))
        return 0


def extrapolated_path(pose: Pose, later: Pose, dt: float):
    """time offset -> Pose moving from ``pose`` (offset 0) with the constant linear and angular
    velocity that takes it to ``later`` in ``dt`` seconds (negative offsets go back in time)."""
    from scipy.spatial.transform import Rotation

    spin = Rotation.from_matrix(later.rotation @ pose.rotation.T).as_rotvec() / dt
    velocity = (later.translation - pose.translation) / dt

    def at(offset: float) -> Pose:
        turn = Rotation.from_rotvec(spin * offset).as_matrix()
        return Pose(turn @ pose.rotation, pose.translation + velocity * offset)

    return at


@dataclasses.dataclass(frozen=True)
class FrameInertia:
    linear_inertia: float = 1.0
    angular_inertia: float = 1.0
    linear_drag: float = 0.0
    angular_drag: float = 0.0


@dataclasses.dataclass(frozen=True)
class IterationTerms:
    """Everything the integrate and wind kernels need from the frame for one iteration."""

    m_cur: np.ndarray  # f32 (3,3)
    m_prev: np.ndarray  # f32 (3,3)
    bias: np.ndarray  # f32 (3,)
    motion_matrix: np.ndarray  # f32 (3,3): frame displacement of local point x is M x + o
    motion_offset: np.ndarray  # f32 (3,)
    to_local: np.ndarray  # f64 (3,3): R_{n+1}^T, rotates world vectors into the frame


@dataclasses.dataclass(frozen=True)
class FrameStacks:
    """The arrays a frame's per-iteration terms are rows of, iteration i at row first + i
    (``rotations`` and ``translations``: the frame's pose at its start at row first, at the
    end of iteration i at row first + i + 1). The frame motion computed ahead
    (FrameMotionAhead) gives every frame of its chain the same arrays with ``first`` moving
    on, so that a stage's arguments to the compiled frame function stay the same objects
    from frame to frame (only the row moves); terms computed for one frame are their own
    stacks from row 0."""

    first: int
    m_cur: np.ndarray  # in the state's precision
    m_prev: np.ndarray
    bias: np.ndarray
    motion_matrix: np.ndarray  # f32
    motion_offset: np.ndarray  # f32
    to_local: np.ndarray  # f64
    pose_pairs: np.ndarray  # f64
    rotations: np.ndarray  # f64
    translations: np.ndarray  # f64
    # the FrameMotionAhead whose chain these arrays are (its in_frame rows line up), or None
    chain: FrameMotionAhead | None = None


class _StackRows:
    """A FrameTerms array: the frame's rows of its stacks' array of the same name (``extra``
    rows more), sliced when first asked for and then kept in the instance."""

    def __init__(self, extra: int = 0):
        self.extra = extra
        self.name = ""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, terms, owner=None) -> Any:
        if terms is None:
            return self
        first = terms.stacks.first
        rows = getattr(terms.stacks, self.name)[first : first + terms.iterations + self.extra]
        terms.__dict__[self.name] = rows  # the instance's own from now on (a non-data descriptor)
        return rows


@dataclasses.dataclass(frozen=True)
class FrameTerms:
    """IterationTerms of every iteration of a frame, stacked (first axis: the iteration), and
    the frame's poses at the iterations' ends, preceded by its pose at the frame's start.
    The arrays are rows of ``stacks`` (what the compiled frame function indexes), sliced
    when first asked for: a frame of the fused bake asks for none of them."""

    stacks: FrameStacks
    iterations: int  # k
    poses: Sequence[Pose]  # k + 1 poses
    # the frame motion computed ahead these rows come from (FrameMotionAhead, its rows), or None
    ahead: tuple | None = None

    m_cur = _StackRows()  # (k,3,3) in the state's precision
    m_prev = _StackRows()
    bias = _StackRows()  # (k,3) in the state's precision
    motion_matrix = _StackRows()  # f32 (k,3,3)
    motion_offset = _StackRows()  # f32 (k,3)
    to_local = _StackRows()  # f64 (k,3,3)
    pose_pairs = _StackRows()  # f64 (k,8,3): each iteration's start and end pose (``pose_pairs``)
    rotations = _StackRows(extra=1)  # f64 (k+1,3,3): the poses' rotations, stacked
    translations = _StackRows(extra=1)  # f64 (k+1,3): ... and translations

    def at(self, index: int) -> IterationTerms:
        return IterationTerms(
            self.m_cur[index], self.m_prev[index], self.bias[index], self.motion_matrix[index], self.motion_offset[index],
            self.to_local[index],
        )

    def in_frame(self, vector: np.ndarray, dtype=np.float64) -> np.ndarray:
        """(k,3) in ``dtype``: the world ``vector`` (3,) in the frame at each iteration's end,
        ``to_local @ vector``; from the frame motion computed ahead when the terms come from
        one (one product for all its frames while the vector stays: the same bits, row by row)."""
        if self.ahead is not None:
            ahead, rows = self.ahead
            return ahead.in_frame(vector, dtype)[rows]
        return np.ascontiguousarray(self.to_local @ vector, dtype)

    def in_frame_rows(self, vector: np.ndarray, dtype=np.float64) -> np.ndarray:
        """``in_frame`` as rows of an array indexed like the stacks (iteration i at row
        first + i): the frame motion's own when the stacks are its chain's, else ``in_frame``."""
        chain = self.stacks.chain
        return chain.in_frame(vector, dtype) if chain is not None else self.in_frame(vector, dtype)


def pose_pairs(rotations: np.ndarray, translations: np.ndarray) -> np.ndarray:
    """f64 (n-1,8,3) of n poses' (n,3,3) ``rotations`` and (n,3) ``translations``: row i is
    pose i (rotation rows 0-2, translation row 3) and pose i+1 (rows 4-7), the cloth frame at
    an iteration's start and end as the collide stage poses the colliders with it."""
    pairs = np.empty((max(rotations.shape[0] - 1, 0), 8, 3))
    pairs[:, 0:3] = rotations[:-1]
    pairs[:, 3] = translations[:-1]
    pairs[:, 4:7] = rotations[1:]
    pairs[:, 7] = translations[1:]
    return pairs


class FrameHistory:
    """The poses at the ends of the last two iterations of one cloth's frame."""

    def __init__(self, pose: Pose):
        self.before = pose  # P_{n-1}
        self.now = pose  # P_n

    def rebase(self, before: Pose, now: Pose) -> None:
        """Replace the pose history (a teleport: the frame continues from a new path)."""
        self.before = before
        self.now = now

    def advance_many(
        self,
        targets: list[Pose],
        scales: np.ndarray,
        gravity: np.ndarray,
        h: float,
        inertia: FrameInertia,
        stiffness_frequency: float,
        dtype=np.float32,
    ) -> "FrameTerms":
        """The terms (module docstring) of the iterations ending at each of ``targets``
        (velocity scales ``scales``), for a whole frame at once: (k,3,3) and (k,3) stacks
        computed together, in the particle state's ``dtype``. The history is left as it is: ``poses`` says where it stands at each
        iteration."""
        rotations = np.stack([self.before.rotation, self.now.rotation] + [t.rotation for t in targets])
        translations = np.stack([self.before.translation, self.now.translation] + [t.translation for t in targets])
        motion = _frame_motion(rotations, translations, gravity, h, inertia, stiffness_frequency)
        return _frame_terms(motion, scales, dtype, [self.now] + list(targets), rotations[1:], translations[1:])

    @property
    def moving(self) -> bool:
        return not (
            np.array_equal(self.before.rotation, self.now.rotation)
            and np.array_equal(self.before.translation, self.now.translation)
        )


def _frame_motion(rotations, translations, gravity, h, inertia: FrameInertia, stiffness_frequency: float) -> tuple:
    """What the terms of the iterations ending at poses 2.. of (n,3,3) ``rotations`` and (n,3)
    ``translations`` owe to the frame's motion alone (not to the velocity scale): q and k
    (n-2,3,3) and b (n-2,3) in float64, the motion matrix (n-2,3,3) and offset (n-2,3) in
    float32, and R^T (n-2,3,3). Row by row, so a row is the same whatever rows go with it."""
    r_prev, r_now, r_next = rotations[:-2], rotations[1:-1], rotations[2:]
    t_prev, t_now, t_next = translations[:-2], translations[1:-1], translations[2:]
    inv = np.ascontiguousarray(r_next.transpose(0, 2, 1))
    d_lin = 1.0 - damping_scale(inertia.linear_drag, stiffness_frequency, h)
    d_ang = 1.0 - damping_scale(inertia.angular_drag, stiffness_frequency, h)
    i_lin, i_ang = inertia.linear_inertia, inertia.angular_inertia
    q = i_ang * (inv @ r_prev) + (1.0 - i_ang) * IDENTITY
    d_n, d_n1 = r_now - r_prev, r_next - r_now
    dt_n, dt_n1 = t_now - t_prev, t_next - t_now
    k = inv @ (i_ang * (d_n - d_n1) - d_ang * d_n1)
    b = (inv @ (i_lin * (dt_n - dt_n1) - d_lin * dt_n1 + gravity * h * h)[:, :, None])[:, :, 0]
    motion_matrix = np.ascontiguousarray(inv @ d_n1, np.float32)
    motion_offset = np.ascontiguousarray((inv @ dt_n1[:, :, None])[:, :, 0], np.float32)
    return q, k, b, motion_matrix, motion_offset, inv


def _scaled(motion: tuple, scales, dtype) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """m_cur, m_prev and bias of ``_frame_motion``'s rows at velocity scales ``scales`` (one
    per row), in the state's ``dtype``; element by element, so a row's bits do not depend on
    the rows computed with it."""
    q, k, b = motion[:3]
    scale = np.asarray(scales, np.float64)[:, None, None]
    return (
        np.ascontiguousarray(scale * q + k, dtype), np.ascontiguousarray(-scale * q, dtype), np.ascontiguousarray(b, dtype)
    )


def _frame_terms(motion: tuple, scales, dtype, poses: Sequence[Pose], rotations, translations) -> FrameTerms:
    """FrameTerms of one frame from ``_frame_motion``'s arrays (its rows only) and the
    iterations' velocity scales: its own stacks, from row 0."""
    m_cur, m_prev, bias = _scaled(motion, scales, dtype)
    motion_matrix, motion_offset, inv = motion[3:]
    stacks = FrameStacks(
        0, m_cur, m_prev, bias, motion_matrix, motion_offset, inv, pose_pairs(rotations, translations), rotations,
        translations,
    )
    return FrameTerms(stacks, motion_matrix.shape[0], poses)


class FrameMotionAhead:
    """The frame motion of many iterations computed at once: ``chain`` (PoseRows) is the pose
    history (P_{n-1}, P_n) followed by the poses at the ends of the next iterations, frames of
    them (a track's planned poses), and ``times`` the seconds of those ends. ``terms`` gives a
    frame's terms from these arrays when its history is the chain's very Pose objects where
    the last frame left it and its iterations end at the chain's next times, at the same
    ``h``: the same bits as ``FrameHistory.advance_many``, which computes the same rows one
    frame at a time."""

    def __init__(
        self, chain: PoseRows, times: list[float], gravity, h: float, inertia: FrameInertia, stiffness_frequency: float
    ):
        self.chain = chain
        self.times = times
        self.h = h
        self._row = 0  # the chain row of the next frame's P_{n-1}
        self.rotations = chain.rotations
        self.translations = chain.translations
        self.motion = _frame_motion(self.rotations, self.translations, gravity, h, inertia, stiffness_frequency)
        self.pose_pairs = pose_pairs(self.rotations, self.translations)
        # FrameStacks of a frame from chain row j: row j is its first iteration's (pose pair) or
        # its start pose (rotations, translations), one row past the chain's
        self._stacked_pairs = self.pose_pairs[1:]
        self._stacked_rotations, self._stacked_translations = self.rotations[1:], self.translations[1:]
        self._scaled: dict[tuple, tuple] = {}  # (scales, dtype) -> the chain's _scaled arrays
        self._last_scaled: tuple = (None, None, None)  # (scales object, dtype, its _scaled arrays)
        self._in_frame: tuple = (None, None)  # (vector bytes, the chain's to_local @ vector)
        self._in_frame_of: tuple = (None, None)  # (the read-only vector, dtype) _in_frame was last asked for
        self._made: tuple = (None, None, {})  # (scales, dtype, {row: FrameTerms}) made ahead (terms)

    def terms(self, history: FrameHistory, ends: list[float], scales, h: float, dtype) -> FrameTerms | None:
        """The terms of the frame from ``history`` through iterations ending at ``ends``
        seconds; None when they are not this chain's next (another path, a teleport, the
        chain's end) or ``h`` differs."""
        chain, j, k = self.chain, self._row, len(ends)
        if h != self.h or j + 2 + k > len(chain) or chain[j] is not history.before or chain[j + 1] is not history.now:
            return None
        if self.times[j : j + k] != ends:
            return None
        self._row = j + k
        made = self._made
        if made[0] is scales and made[1] is dtype and j in made[2]:
            return made[2][j]
        if self._last_scaled[0] is scales and self._last_scaled[1] is dtype and j % k == 0:
            # the solver's scales as last frame (every frame of a usual bake): the terms of the
            # chain's remaining frames made together, in one loop while the processor's caches
            # are warm, not each between two frames' compiled calls (~10 us a frame there)
            frames = {row: self._terms_at(row, k, scales, dtype) for row in range(j, self.motion[0].shape[0] - k + 1, k)}
            self._made = (scales, dtype, frames)
            return frames[j]
        return self._terms_at(j, k, scales, dtype)

    def _terms_at(self, j: int, k: int, scales, dtype) -> FrameTerms:
        """The terms of the frame of ``k`` iterations from chain row ``j`` (its P_{n-1}): rows
        of the chain's stacks, or (scales that give no chain-long stacks) the frame's own."""
        rows = slice(j, j + k)
        scaled = self._scaled_rows(scales, dtype, j, k)
        if scaled is None:
            first, (m_cur, m_prev, bias) = 0, _scaled(tuple(array[rows] for array in self.motion), scales, dtype)
            motion_matrix, motion_offset, to_local = (array[rows] for array in self.motion[3:])
            pairs = self.pose_pairs[j + 1 : j + 1 + k]
            rotations, translations, chain = self.rotations[j + 1 : j + 2 + k], self.translations[j + 1 : j + 2 + k], None
        else:  # every term a row of the chain's arrays
            first, (m_cur, m_prev, bias) = j, scaled
            motion_matrix, motion_offset, to_local = self.motion[3:]
            pairs, rotations, translations, chain = self._stacked_pairs, self._stacked_rotations, self._stacked_translations, self
        stacks = FrameStacks(first, m_cur, m_prev, bias, motion_matrix, motion_offset, to_local, pairs, rotations, translations,
                             chain)
        return FrameTerms(stacks, k, self.chain[j + 1 : j + 2 + k], (self, rows))

    def in_frame(self, vector: np.ndarray, dtype=np.float64) -> np.ndarray:
        """(n-2,3) in ``dtype``: ``vector`` (3,) in the frame at the end of each of the chain's
        iterations (R^T v), for the last vector and dtype asked for (a still or steady wind:
        every frame; converted once, element by element: the bits of converting a frame's rows)."""
        if vector is self._in_frame_of[0] and dtype is self._in_frame_of[1]:  # a read-only vector asked again
            return self._in_frame[1]
        key = (np.asarray(vector, np.float64).tobytes(), np.dtype(dtype))
        if self._in_frame[0] != key:
            self._in_frame = (key, np.ascontiguousarray(self.motion[5] @ vector, dtype))
        self._in_frame_of = (vector, dtype) if isinstance(vector, np.ndarray) and not vector.flags.writeable else (None, None)
        return self._in_frame[1]

    def _scaled_rows(self, scales, dtype, j: int, k: int):
        """``_scaled`` of every row of the chain with each frame's iterations at ``scales``
        (computed once for the chain, then sliced per frame: the same elementwise bits);
        None when row ``j`` does not start a frame of ``k`` iterations."""
        if j % k:
            return None
        last_scales, last_dtype, scaled = self._last_scaled
        if scales is last_scales and dtype is last_dtype:  # the solver's scales as last frame: no key to build
            return scaled
        key = (np.asarray(scales, np.float64).tobytes(), np.dtype(dtype))
        scaled = self._scaled.get(key)
        if scaled is None:
            rows = self.motion[0].shape[0]
            scaled = self._scaled[key] = _scaled(self.motion, np.resize(np.asarray(scales, np.float64), rows), dtype)
        self._last_scaled = (scales, dtype, scaled)
        return scaled
