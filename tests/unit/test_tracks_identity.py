"""A track that never turns (every key's rotation the identity) is sampled without slerps:
the same bits as interpolating the identities, which give the identity exactly; a cloth's
rigid frame is sampled without its scales, with the same translations and rotations; and
tracks sampled together give each the bits of sampling it alone."""

from __future__ import annotations

import numpy as np
import pytest

from clothtool.scene.tracks import Track, euler_xyz_to_quat, sample_tracks


def _track(interpolation: str, keys: int, rotations=None) -> Track:
    rng = np.random.default_rng(keys)
    times = np.cumsum(rng.uniform(0.1, 0.5, keys))
    identity = np.tile([1.0, 0.0, 0.0, 0.0], (keys, 1))
    return Track("t", times, rng.normal(size=(keys, 3)), identity if rotations is None else rotations,
                 rng.uniform(0.5, 2.0, (keys, 3)), interpolation)


def _times(track: Track) -> np.ndarray:
    rng = np.random.default_rng(7)
    inside = rng.uniform(track.times[0], track.times[-1], 200)
    return np.concatenate([[track.times[0] - 1.0], track.times, inside, [track.times[-1] + 1.0]])


@pytest.mark.parametrize("interpolation, keys", [("linear", 2), ("linear", 5), ("cubic", 2), ("cubic", 6)])
def test_a_track_that_never_turns_samples_the_bits_of_slerping_identities(interpolation, keys):
    track = _track(interpolation, keys)
    assert track._never_turns()
    times = _times(track)
    translations, rotations, scales = track.sample_many(times)
    slerped = _track(interpolation, keys)
    object.__setattr__(slerped, "_never", False)  # the interpolating path, as for any other track
    expected = slerped.sample_many(times)
    for got, want in zip((translations, rotations, scales), expected):
        assert got.dtype == want.dtype and got.shape == want.shape
        assert got.tobytes() == want.tobytes()  # bit for bit, the signs of zeros included
    np.testing.assert_array_equal(rotations, np.tile([1.0, 0.0, 0.0, 0.0], (times.shape[0], 1)))


def test_a_turning_track_is_slerped():
    rotations = np.array([euler_xyz_to_quat([0.0, 0.0, 0.0]), euler_xyz_to_quat([0.0, 90.0, 0.0])])
    track = _track("linear", 2, rotations)
    assert not track._never_turns()
    _, sampled, _ = track.sample_many(np.array([track.times[0] + 0.5 * (track.times[1] - track.times[0])]))
    np.testing.assert_allclose(sampled[0], euler_xyz_to_quat([0.0, 45.0, 0.0]), atol=1e-12)


@pytest.mark.parametrize("interpolation", ["step", "linear", "cubic"])
def test_sampling_without_scales_keeps_translations_and_rotations(interpolation):
    rotations = np.array([euler_xyz_to_quat([10.0 * i, 5.0 * i, 0.0]) for i in range(4)])
    track = _track(interpolation, 4, rotations)
    times = _times(track)
    full = track.sample_many(times)
    rigid = track.sample_many(times, scales=False)
    assert rigid[2] is None
    for got, want in zip(rigid[:2], full[:2]):
        assert got.tobytes() == want.tobytes()


def _turning(interpolation: str, keys: int, seed: int) -> Track:
    rng = np.random.default_rng(seed)
    rotations = np.array([euler_xyz_to_quat(rng.uniform(-90.0, 90.0, 3)) for _ in range(keys)])
    return _track(interpolation, keys, rotations)


def test_tracks_sampled_together_are_the_bits_of_each_alone():
    def tracks():
        return [_turning("cubic", 5, 1), _track("cubic", 4), _turning("cubic", 3, 2), _turning("linear", 4, 3),
                _turning("step", 3, 4), _turning("cubic", 2, 5), _track("linear", 1), _turning("cubic", 7, 6)]

    alone = tracks()  # sampled one by one, each computing its own Bezier controls
    times = _times(alone[-1])
    together = sample_tracks(tracks(), times)
    assert len(together) == len(alone)
    for track, got in zip(alone, together):
        expected = track.sample_many(times)
        for a, b in zip(got, expected):
            assert a.shape == b.shape and a.tobytes() == b.tobytes(), track.interpolation
    assert sample_tracks([], times) == []
