"""Mode "auto" from a point-like start (method page *Extended objects*, §3.4): stage 1 tracks
the point, its confirmed trajectory seeds a stage-2 group once its segment grows, the group
starts with stage 1's velocity and observation count; the seeded tracker equals its twin;
streaming == batch; pickling mid-scene resumes exactly."""

from __future__ import annotations

import pickle

import numpy as np
from test_detect import same
from test_stage2 import CONFIG, random_scene

import kalmanfield as kf
from kalmanfield import _core
from kalmanfield.reference.extended import GroupTracker as TwinTracker

OPTIONS = dict(noise_std=1.0, smooth=1, threshold_k=4.0, min_area=1)
VELOCITY = (3.0, 2.0)


def growing_scene(seed: int = 0, n: int = 14, grow_at: int = 6) -> np.ndarray:
    """A 2-pixel point moving at VELOCITY px/frame that becomes, at `grow_at`, two discs of
    13 pixels 6 px apart (two fragments of one object)."""
    rng = np.random.default_rng(seed)
    frames = rng.normal(0.0, 1.0, (n, 60, 60))
    yy, xx = np.mgrid[0:60, 0:60]
    for t in range(n):
        cx, cy = 8 + VELOCITY[0] * t, 10 + VELOCITY[1] * t
        if t < grow_at:
            frames[t, int(cy), int(cx) : int(cx) + 2] += 30.0
        else:
            for dx in (-3.0, 3.0):
                frames[t][(xx - cx - dx) ** 2 + (yy - cy) ** 2 <= 4] += 30.0
    return frames


def test_point_that_grows_is_one_object_seeded_by_stage_one():
    frames = growing_scene()
    det = kf.MovingObjectDetector(**OPTIONS)
    for f in frames:
        det.update(f)
    assert det.mode == "staged"
    objects = det.objects()
    assert len(objects) == 1
    o = objects[0]
    assert o.frames.tolist() == list(range(14))  # no gap at the hand-over
    # frame 7: the first stage-2 frame. A group without stage 1's velocity and length would
    # have velocity 0 and no member (length ≤ ν + 1) there; seeded, it is detected at once
    # with stage 1's velocity.
    row = o.track[o.track["frame"] == 7].iloc[0]
    np.testing.assert_allclose([row.vx, row.vy], VELOCITY, atol=0.6)
    late = o.fragments[o.fragments["frame"] >= 11]
    assert late.groupby("frame").size().min() == 2  # both fragments, one object
    assert o.mask(12).sum() == 26


def test_staged_streaming_equals_batch_and_pickle_resumes():
    frames = growing_scene(seed=1)
    batch = kf.detect_moving_objects(frames, **OPTIONS)
    stream = kf.detect_moving_objects((f for f in frames), **OPTIONS)
    same(batch, stream)
    a = kf.MovingObjectDetector(**OPTIONS)
    for f in frames[:7]:
        a.update(f)
    b = pickle.loads(pickle.dumps(a))
    for f in frames[7:]:
        a.update(f)
        b.update(f)
    same(a.objects(), b.objects())
    same(a.objects(), batch)


def test_point_mode_never_seeds():
    objects = kf.detect_moving_objects(growing_scene(), mode="point", **OPTIONS)
    # stage 1 alone: one fragment per frame, the grown object's second disc is another track
    assert all(o.fragments.groupby("frame").size().max() == 1 for o in objects)


def test_seeded_tracker_equals_twin():
    for seed in range(4):
        rng = np.random.default_rng(100 + seed)
        frames = random_scene(rng)
        config = dict(CONFIG, seed_groups=bool(seed % 2))
        rust, twin = _core.GroupTracker(**config), TwinTracker(config)
        z = np.ascontiguousarray(frames[0][:2])
        v = rng.uniform(-2, 2, 2)
        length = int(rng.integers(1, 6))
        assert rust.seed(z, v[0], v[1], length) == twin.seed(z, v[0], v[1], length)
        for z in frames[1:]:
            a = rust.step(np.ascontiguousarray(z))
            group, sequence, member, groups, _ = twin.step(z)
            np.testing.assert_array_equal(a["segment_group"], group)
            np.testing.assert_array_equal(a["segment_sequence"], sequence)
            np.testing.assert_array_equal(a["segment_member"], member)
            np.testing.assert_allclose(a["groups"], groups, rtol=1e-10, atol=1e-10)


def test_seed_length_makes_members_at_once():
    t = _core.GroupTracker(**CONFIG)
    blob = [10.0, 10.0, 10.0, 9.0, 9.0, 9.0, 11.0, 11.0]
    t.seed(np.array([blob]), 2.0, 0.0, 5)
    moved = np.array([[12.0, 10.0, 10.0, 9.0, 11.0, 9.0, 13.0, 11.0]])
    a = t.step(moved)
    assert a["segment_member"].tolist() == [True]
    np.testing.assert_allclose(a["groups"][0, 3:5], [2.0, 0.0], atol=0.1)
