"""Animated tracks: keyframed or sampled translation, rotation and scale over time.

Rotations are unit quaternions (w, x, y, z), interpolated by slerp along the shorter arc;
a matrix keyframe is decomposed into translation, rotation and scale first, so matrices
are never interpolated component-wise. Interpolation is ``step``, ``linear`` or ``cubic``
(Catmull-Rom on translation and scale; rotation by spherical cubic Bezier through the
Catmull-Rom tangents, which reduces to slerp for two keys).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from clothtool.errors import SceneError

INTERPOLATIONS = ("step", "linear", "cubic")


# ------------------------------------------------------------------------ quaternions
def quat_normalize(q: np.ndarray) -> np.ndarray:
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ]
    )


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    return quat_to_matrices(np.asarray(q, np.float64)[None])[0]


def quat_to_matrices(q: np.ndarray) -> np.ndarray:
    """(m,3,3) rotation matrices of (m,4) quaternions (w, x, y, z), normalised first."""
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=1,
    )


def matrix_to_quat(m: np.ndarray) -> np.ndarray:
    """Unit quaternion of a rotation matrix (Shepperd's method, numerically safe)."""
    trace = np.trace(m)
    if trace > 0:
        s = 2.0 * np.sqrt(1.0 + trace)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q = np.asarray(q)
    return q / np.linalg.norm(q)


def euler_xyz_to_quat(degrees) -> np.ndarray:
    """Rotation about X, then Y, then Z (extrinsic), angles in degrees."""
    ax, ay, az = np.radians(np.asarray(degrees, np.float64))
    qx = np.array([np.cos(ax / 2), np.sin(ax / 2), 0.0, 0.0])
    qy = np.array([np.cos(ay / 2), 0.0, np.sin(ay / 2), 0.0])
    qz = np.array([np.cos(az / 2), 0.0, 0.0, np.sin(az / 2)])
    return quat_multiply(qz, quat_multiply(qy, qx))


def quat_conjugate(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def quat_log(q: np.ndarray) -> np.ndarray:
    """(m,3) rotation vectors / 2 of (m,4) unit quaternions (their logarithms' vector parts)."""
    v = q[:, 1:]
    s = np.linalg.norm(v, axis=1, keepdims=True)
    turned = s >= 1e-12
    return np.where(turned, v / np.where(turned, s, 1.0) * np.arctan2(s, q[:, :1]), 0.0)


def quat_exp(v: np.ndarray) -> np.ndarray:
    """(m,4) unit quaternions of (m,3) logarithms (``quat_log``'s inverse)."""
    angle = np.linalg.norm(v, axis=1, keepdims=True)
    turned = angle >= 1e-12
    axis_part = np.where(turned, np.sin(angle) * v / np.where(turned, angle, 1.0), 0.0)
    return np.concatenate([np.where(turned, np.cos(angle), 1.0), axis_part], axis=1)


def slerp_many(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``slerp`` of (m,4) quaternion rows at (m,) parameters, row by row."""
    dot = np.einsum("ij,ij->i", a, b)
    b = np.where(dot[:, None] < 0.0, -b, b)
    dot = np.abs(dot)
    t = t[:, None]
    near = (dot > 0.9995)[:, None]  # nearly parallel: lerp is accurate and avoids dividing by sin ~ 0
    lerped = a + t * (b - a)
    lerped /= np.linalg.norm(lerped, axis=1, keepdims=True)
    theta = np.arccos(np.minimum(dot, 1.0))[:, None]
    sin = np.where(near, 1.0, np.sin(theta))
    arc = (np.sin((1 - t) * theta) * a + np.sin(t * theta) * b) / sin
    return np.where(near, lerped, arc)


def slerp(a: np.ndarray, b: np.ndarray, t: float) -> np.ndarray:
    """Spherical interpolation of two unit quaternions along the shorter arc."""
    return slerp_many(np.asarray(a, np.float64)[None], np.asarray(b, np.float64)[None], np.array([float(t)]))[0]


def decompose_matrix(m: np.ndarray, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """4x4 (column-vector convention: translation in the last column) -> (t, q, scale)."""
    m = np.asarray(m, np.float64)
    if m.shape != (4, 4):
        raise SceneError(f"{where}: a matrix key needs 4 rows of 4 numbers")
    linear = m[:3, :3]
    scale = np.linalg.norm(linear, axis=0)
    if np.any(scale <= 0):
        raise SceneError(f"{where}: the matrix is singular; give a rotation and a non-zero scale")
    rotation = linear / scale
    if np.linalg.det(rotation) < 0:
        raise SceneError(f"{where}: the matrix mirrors (negative determinant), which a track cannot animate")
    if not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-4):
        raise SceneError(f"{where}: the matrix has shear; tracks take translation, rotation and scale only")
    return m[:3, 3].copy(), matrix_to_quat(rotation), scale


# ------------------------------------------------------------------------ tracks
@dataclasses.dataclass(frozen=True)
class TrackSample:
    translation: np.ndarray  # (3,)
    rotation: np.ndarray  # (4,) unit quaternion (w, x, y, z)
    scale: np.ndarray  # (3,)

    def rotation_matrix(self) -> np.ndarray:
        return quat_to_matrix(self.rotation)

    def matrix(self) -> np.ndarray:
        """4x4 local->world, column-vector convention (translation in the last column)."""
        m = np.eye(4)
        m[:3, :3] = self.rotation_matrix() * self.scale
        m[:3, 3] = self.translation
        return m


@dataclasses.dataclass(frozen=True, eq=False)
class Track:
    """Keys at strictly increasing ``times`` (seconds), interpolated between them and held
    constant outside them.

    Attributes:
        name: the track's name (for messages).
        times: f64 (k,) seconds.
        translations: f64 (k,3); rotations: f64 (k,4) unit quaternions; scales: f64 (k,3).
        interpolation: "step", "linear" or "cubic".
        teleport_frames: frames at whose start the animated object jumps (no velocity).
    """

    name: str
    times: np.ndarray
    translations: np.ndarray
    rotations: np.ndarray
    scales: np.ndarray
    interpolation: str = "linear"
    teleport_frames: frozenset[int] = frozenset()

    def __post_init__(self):
        where = f"track '{self.name}'"
        if self.interpolation not in INTERPOLATIONS:
            raise SceneError(f"{where}: interpolation '{self.interpolation}' is not one of {', '.join(INTERPOLATIONS)}")
        k = self.times.shape[0]
        if k == 0:
            raise SceneError(f"{where}: has no keys; give at least one")
        for name, array, width in (("translate", self.translations, 3), ("rotate", self.rotations, 4), ("scale", self.scales, 3)):
            if array.shape != (k, width):
                raise SceneError(f"{where}: '{name}' has shape {array.shape}, expected ({k}, {width})")
            bad = ~np.isfinite(array).all(axis=1)
            if bad.any():
                raise SceneError(f"{where}: key {int(np.flatnonzero(bad)[0])} has a NaN or infinite '{name}' value; fix it")
        if not np.isfinite(self.times).all():
            raise SceneError(f"{where}: key {int(np.flatnonzero(~np.isfinite(self.times))[0])} has a NaN time")
        order = np.diff(self.times)
        if np.any(order <= 0):
            i = int(np.flatnonzero(order <= 0)[0]) + 1
            raise SceneError(
                f"{where}: key {i} at time {self.times[i]:g} s does not come after key {i - 1} at {self.times[i - 1]:g} s; "
                "sort the keys by time"
            )
        norms = np.linalg.norm(self.rotations, axis=1)
        if np.any(norms < 1e-9):
            raise SceneError(f"{where}: key {int(np.argmin(norms))} has a zero quaternion; give a unit rotation (w, x, y, z)")
        rotations = self.rotations / norms[:, None]
        # q and -q are the same rotation: flip keys onto one hemisphere so that
        # interpolation between neighbours takes the shorter arc
        for j in range(1, k):
            if np.dot(rotations[j - 1], rotations[j]) < 0:
                rotations[j] = -rotations[j]
        object.__setattr__(self, "rotations", rotations)
        if np.any(self.scales <= 0):
            raise SceneError(f"{where}: key {int(np.flatnonzero((self.scales <= 0).any(axis=1))[0])} has a non-positive scale")

    @property
    def is_static(self) -> bool:
        return self.times.shape[0] == 1 or (
            np.ptp(self.translations, axis=0).max() == 0
            and np.ptp(self.rotations, axis=0).max() == 0
            and np.ptp(self.scales, axis=0).max() == 0
        )

    def sample(self, time: float) -> TrackSample:
        """The pose at ``time`` seconds. The last few samples are kept: a bake asks for a
        collider's pose at a frame's end, then again at the next frame's start and for the
        cache's transforms (the arrays are shared: do not modify them)."""
        prefetched = self.__dict__.get("_prefetched")
        if prefetched is not None:
            rows, (translations, rotations, scales) = prefetched
            row = rows.get(time)
            if row is not None:
                return TrackSample(translations[row], rotations[row], scales[row])
        recent = self.__dict__.setdefault("_recent", {})
        sample = recent.get(time)
        if sample is None:
            translations, rotations, scales = self.sample_many(np.array([float(time)]))
            sample = recent[time] = TrackSample(translations[0], rotations[0], scales[0])
            if len(recent) > 8:
                del recent[next(iter(recent))]
        return sample

    def prefetch(self, times, samples=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sample all of ``times`` now, in one vectorised call (a bake's frame times): later
        ``sample`` calls at these times find them. Returns ``sample_many(times)``, or keeps
        ``samples`` when given (what ``sample_many(times)`` gives, e.g. from sample_tracks)."""
        times = np.asarray(times, np.float64)
        samples = self.sample_many(times) if samples is None else samples
        self.__dict__["_prefetched"] = ({float(t): row for row, t in enumerate(times)}, samples)
        return samples

    def sample_many(self, times: np.ndarray, scales: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """Translations (m,3), unit quaternions (m,4) and scales (m,3) at (m,) ``times``
        in seconds, all at once (a frame's iterations sample the track together). Without
        ``scales`` the scales are not interpolated (None): a cloth's moving frame is rigid."""
        times = np.asarray(times, np.float64)
        k = self.times.shape[0]
        if k == 1:
            m = times.shape[0]
            return (np.repeat(self.translations, m, 0), np.repeat(self.rotations, m, 0),
                    np.repeat(self.scales, m, 0) if scales else None)
        i = np.clip(np.searchsorted(self.times, times, side="right") - 1, 0, k - 2)
        u = np.clip((times - self.times[i]) / (self.times[i + 1] - self.times[i]), 0.0, 1.0)
        if self.interpolation == "step":
            i = np.where(u >= 1.0, i + 1, i)  # at or past a segment's end key: that key
            return self.translations[i], self.rotations[i], self.scales[i] if scales else None
        if self.interpolation == "linear" or k == 2:
            lerp = lambda a: a[i] + u[:, None] * (a[i + 1] - a[i])  # noqa: E731
            rotations = self._identities(i) if self._never_turns() else slerp_many(self.rotations[i], self.rotations[i + 1], u)
            return lerp(self.translations), rotations, lerp(self.scales) if scales else None
        rotations = self._identities(i) if self._never_turns() else self._spherical_cubic(i, u)
        return self._catmull_rom(self.translations, i, u), rotations, self._catmull_rom(self.scales, i, u) if scales else None

    def _never_turns(self) -> bool:
        """True when every key's rotation is exactly the identity (1, +0, +0, +0): a track of
        translations (and scales) alone. Slerp and the spherical cubic between identities
        give the identity exactly (tests/unit/test_tracks_identity.py), so sampling skips
        them: they are most of a long sample's cost (~0.5 ms for a bake's 600 iteration ends)."""
        never = self.__dict__.get("_never")
        if never is None:
            identity = np.array([1.0, 0.0, 0.0, 0.0])
            never = bool(np.array_equal(self.rotations, np.broadcast_to(identity, self.rotations.shape))
                         and not np.signbit(self.rotations).any())
            object.__setattr__(self, "_never", never)
        return never

    @staticmethod
    def _identities(i: np.ndarray) -> np.ndarray:
        rotations = np.zeros((i.shape[0], 4))
        rotations[:, 0] = 1.0
        return rotations

    def _neighbours(self, i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return np.maximum(i - 1, 0), np.minimum(i + 2, self.times.shape[0] - 1)

    def _catmull_rom(self, values: np.ndarray, i: np.ndarray, u: np.ndarray) -> np.ndarray:
        return _catmull_rom(values, self.times, i, *self._neighbours(i), u)

    def _spherical_cubic(self, i: np.ndarray, u: np.ndarray) -> np.ndarray:
        return _spherical_cubic(self.rotations, self._bezier_controls(), i, i, u)

    def _bezier_controls(self) -> np.ndarray:
        """(k-1, 2, 4): each segment's inner control quaternions, computed once per track."""
        controls = self.__dict__.get("_controls")
        if controls is None:
            i = np.arange(self.times.shape[0] - 1)
            controls = _bezier_controls(self.rotations, i, *self._neighbours(i))
            object.__setattr__(self, "_controls", controls)
        return controls


def _bezier_controls(q: np.ndarray, i, a, d) -> np.ndarray:
    """(segments, 2, 4): the inner control quaternions of the segments from key rotations i
    to i+1 (a and d the keys before and after them), row by row."""
    q0, q1, q2, q3 = q[a].T, q[i].T, q[i + 1].T, q[d].T  # quat_multiply takes components first
    first = quat_exp(quat_log(quat_multiply(quat_conjugate(q0), q2).T) / 6.0)
    second = quat_exp(-quat_log(quat_multiply(quat_conjugate(q1), q3).T) / 6.0)
    return np.stack([quat_multiply(q1, first.T).T, quat_multiply(q2, second.T).T], axis=1)


def _catmull_rom(values: np.ndarray, t: np.ndarray, i, a, d, u: np.ndarray) -> np.ndarray:
    """Non-uniform Catmull-Rom (tangents from the neighbouring keys' times) of key ``values``
    at key ``t`` seconds: each row between keys i and i+1 at parameter u, a and d the keys
    before and after them. Row by row: a row's bits do not depend on the rows with it."""
    following = i + 1
    t_i, t_next = t[i], t[following]  # each gathered once (a bake samples hundreds of rows)
    v_i, v_next = values[i], values[following]
    span = (t_next - t_i)[:, None]
    m1 = (v_next - values[a]) / (t_next - t[a])[:, None] * span
    m2 = (values[d] - v_i) / (t[d] - t_i)[:, None] * span
    u = u[:, None]
    u2, u3 = u * u, u * u * u
    return (2 * u3 - 3 * u2 + 1) * v_i + (u3 - 2 * u2 + u) * m1 + (-2 * u3 + 3 * u2) * v_next + (u3 - u2) * m2


def _spherical_cubic(rotations: np.ndarray, controls: np.ndarray, i, c, u: np.ndarray) -> np.ndarray:
    """Quaternion Catmull-Rom: a spherical Bezier (de Casteljau with slerp) whose inner
    control points (``controls`` row c, Track._bezier_controls) sit a third of the tangent
    along, tangents taken in log space; row by row, between key rotations i and i+1."""
    q1, q2, c1, c2 = rotations[i], rotations[i + 1], controls[c, 0], controls[c, 1]
    ab, bc, cd = slerp_many(q1, c1, u), slerp_many(c1, c2, u), slerp_many(c2, q2, u)
    result = slerp_many(slerp_many(ab, bc, u), slerp_many(bc, cd, u), u)
    return result / np.linalg.norm(result, axis=1, keepdims=True)


def sample_tracks(tracks, times) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``track.sample_many(times)`` of each of ``tracks``, with the same bits, the turning
    cubic ones interpolated together: their keys stacked end to end, so each numpy operation
    of the interpolation (a few microseconds whatever its length, some fifty of them) runs
    once for all of them (a bake's animated bodies at its frame times: one pass, not one each)."""
    times = np.asarray(times, np.float64)
    together = [track for track in tracks
                if track.interpolation == "cubic" and track.times.shape[0] > 2 and not track._never_turns()]
    if len(together) < 2:
        return [track.sample_many(times) for track in tracks]
    rows, neighbours, segments, parameters, first_keys = [], [], [], [], []
    keys = segments_before = 0
    for track in together:
        k = track.times.shape[0]
        i = np.clip(np.searchsorted(track.times, times, side="right") - 1, 0, k - 2)
        parameters.append(np.clip((times - track.times[i]) / (track.times[i + 1] - track.times[i]), 0.0, 1.0))
        a, d = track._neighbours(i)
        rows.append(i + keys)
        neighbours.append((a + keys, d + keys))
        segments.append(i + segments_before)  # the track's control rows follow the previous tracks'
        first_keys.append(keys)
        keys += k
        segments_before += k - 1
    i, u, c = np.concatenate(rows), np.concatenate(parameters), np.concatenate(segments)
    a, d = np.concatenate([n[0] for n in neighbours]), np.concatenate([n[1] for n in neighbours])
    t = np.concatenate([track.times for track in together])
    key_rotations = np.concatenate([track.rotations for track in together])
    translations = _catmull_rom(np.concatenate([track.translations for track in together]), t, i, a, d, u)
    scales = _catmull_rom(np.concatenate([track.scales for track in together]), t, i, a, d, u)
    rotations = _spherical_cubic(key_rotations, _controls_of(together, key_rotations, first_keys), i, c, u)
    m = times.shape[0]
    sampled = {id(track): (translations[n * m:(n + 1) * m], rotations[n * m:(n + 1) * m], scales[n * m:(n + 1) * m])
               for n, track in enumerate(together)}
    return [sampled[id(track)] if id(track) in sampled else track.sample_many(times) for track in tracks]


def _controls_of(tracks, key_rotations: np.ndarray, first_keys: list[int]) -> np.ndarray:
    """The tracks' Bezier controls stacked (Track._bezier_controls), those not yet computed
    computed together from ``key_rotations`` (the tracks' key rotations stacked, track n's
    from row first_keys[n]) and kept on their tracks."""
    missing = [n for n, track in enumerate(tracks) if "_controls" not in track.__dict__]
    if len(missing) > 1:
        rows, before, after = [], [], []
        for n in missing:
            segment = np.arange(tracks[n].times.shape[0] - 1)
            a, d = tracks[n]._neighbours(segment)
            rows.append(segment + first_keys[n])
            before.append(a + first_keys[n])
            after.append(d + first_keys[n])
        controls = _bezier_controls(key_rotations, np.concatenate(rows), np.concatenate(before), np.concatenate(after))
        start = 0
        for n, segment in zip(missing, rows):
            object.__setattr__(tracks[n], "_controls", controls[start:start + segment.shape[0]])
            start += segment.shape[0]
    return np.concatenate([track._bezier_controls() for track in tracks])


def static_track(name: str, translation=(0.0, 0.0, 0.0), rotation=(1.0, 0.0, 0.0, 0.0), scale=(1.0, 1.0, 1.0)) -> Track:
    return Track(
        name,
        np.zeros(1),
        np.asarray([translation], np.float64),
        np.asarray([rotation], np.float64),
        np.asarray([scale], np.float64),
    )
