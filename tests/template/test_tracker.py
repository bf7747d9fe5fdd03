"""TemplateTracker: Rust == the NumPy twin, the Kalman link == FilterPy, re-acquisition,
several templates, streaming == batch, pickling, bad input."""

import pickle

import numpy as np
import pandas as pd
import pytest

from kalmanfield import TemplateTracker, match_template
from kalmanfield.reference.template import TwinTracker

SETTINGS = [
    dict(process_std=0.05, measurement_std=0.5),
    dict(process_std=0.05, measurement_std=0.5, update_template=0.2),
    dict(process_std=0.3, measurement_std=1.0, model="velocity", gate=2.5, collapse=0.6),
    dict(process_std=0.1, subpixel=False, initial_std=(2.0, 3.0, 0.5)),
]


def _leave_and_return(k):
    # out of the frame for frames 15..21, then back on its path
    return (200.0 if 15 <= k < 22 else 10 + 1.3 * k + 0.02 * k * k), 20 + 8 * np.sin(k / 7)


def _rust_and_twin(frames, template, start, settings):
    """(Rust tracker, twin, Rust steps), asserting frame by frame that the two agree."""
    rust = TemplateTracker(template, start, **settings)
    twin = TwinTracker([template], [start], **settings)
    steps = []
    for frame in frames:
        s, t = rust.update(frame), twin.update(frame)[0]
        np.testing.assert_allclose(s.state, t["mean"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(s.covariance, t["cov"], rtol=1e-12, atol=1e-12)
        assert (s.collapsed, s.reacquired, s.window) == (
            t["collapsed"],
            t["reacquired"],
            t["window"],
        )
        assert s.score == pytest.approx(t["score"], abs=1e-10, nan_ok=True)
        steps.append(s)
    return rust, twin, steps


@pytest.mark.parametrize("settings", SETTINGS)
def test_rust_equals_twin(scene, settings):
    frames, template, truth = scene(path=_leave_and_return)
    rust, twin, steps = _rust_and_twin(frames, template, truth[0], settings)
    flags = [s.collapsed for s in steps]
    assert any(flags) and not all(flags)  # both branches ran
    np.testing.assert_allclose(rust.templates[0], twin.templates[0], atol=1e-12)


def test_kalman_link_equals_filterpy(scene):
    filterpy = pytest.importorskip("filterpy.kalman")
    frames, template, truth = scene(path=_leave_and_return)
    tracker = TemplateTracker(template, truth[0], process_std=0.05, measurement_std=0.5)
    kf = None
    for frame in frames:
        s = tracker.update(frame)
        if kf is None:
            f, q, h, r = tracker.model_matrices()
            kf = filterpy.KalmanFilter(dim_x=6, dim_z=2)
            kf.F, kf.Q, kf.H, kf.R = f, q, h, r
            kf.x = np.array([truth[0][0], 0, 0, truth[0][1], 0, 0], float)
            kf.P = np.diag(np.tile([0.5**2, 5.0**2, 1.0**2], 2))
        elif s.reacquired:
            kf.x = s.state.copy()
            kf.P = s.covariance.copy()
        else:
            kf.predict()
            if s.coasted:  # lost lock: the prior's velocity and acceleration variances added
                kf.P = kf.P + np.diag(np.tile([0.0, 5.0**2, 1.0**2], 2))
        if not s.coasted and not s.reacquired:
            kf.update(np.array([s.x_measured, s.y_measured]))
        np.testing.assert_allclose(s.state, kf.x, atol=1e-9)
        np.testing.assert_allclose(s.covariance, kf.P, atol=1e-9)
    assert tracker.frame == len(frames)


@pytest.mark.parametrize("initial_std, whole_frame", [(None, False), ((0.5, 0.2, 0.05), True)])
def test_reacquisition_after_the_target_leaves_and_reenters(scene, initial_std, whole_frame):
    # leaves through the right edge (x > 69 from frame 22 on), re-enters from the left (x ≥ 0
    # from frame 31 on). With the default prior (velocity std 5 px/frame) the lost-lock rule
    # widens the gate to the whole frame within a few coasted frames and the target is found
    # in it; with a tight prior the gate stays small and the whole-frame search re-acquires.
    def path(k):
        return (6 + 3.0 * k if k < 25 else 2 + 2.0 * (k - 32)), 25.0

    frames, template, truth = scene(n=45, path=path, snr=3.0, shape=(60, 80))
    tracker = TemplateTracker(
        template, truth[0], process_std=0.05, measurement_std=0.5, initial_std=initial_std
    )
    track = tracker.track(frames)
    gone = track[(track.frame >= 22) & (track.frame < 31)]
    assert gone.coasted.all() and not gone.reacquired.any()
    back = track[track.frame >= 31]
    assert back.reacquired.any() == whole_frame
    first = back[~back.coasted].frame.iloc[0]
    assert first <= 32 and back[back.frame == first].reacquired.item() == whole_frame
    after = track[track.frame > first]
    true_x = np.array([path(k)[0] for k in after.frame])
    assert np.abs(after.x - true_x).max() < 1.0 and np.abs(after.y - 25).max() < 1.0


def test_a_peak_outside_the_gate_ellipse_is_not_taken():
    # position std 2, R = 1: S = 5 I, gate 3. The window holds positions 22..38 × 12..28;
    # (38, 28) is in it but outside the ellipse (ν = (8, 8) shrunk to 7.5: 2·7.5²/5 = 22.5 > 9)
    rng = np.random.default_rng(3)
    template = rng.standard_normal((7, 7))
    frame = 0.05 * rng.standard_normal((60, 80))
    frame[20:27, 30:37] += template + 0.5 * rng.standard_normal((7, 7))
    frame[28:35, 38:45] += template
    settings = dict(process_std=0.1, measurement_std=1.0, initial_std=(2.0, 1.0, 0.1))
    step = TemplateTracker(template, (30, 20), **settings).update(frame)
    x, y, score = match_template(frame, template, window=step.window)
    assert (round(x), round(y)) == (38, 28) and score > 0.99  # the window's own peak
    assert abs(step.x_measured - 30) < 0.5 and abs(step.y_measured - 20) < 0.5
    assert step.score < 0.95 and not step.collapsed
    twin = TwinTracker([template], [(30, 20)], **settings).update(frame)[0]
    np.testing.assert_allclose(twin["measurement"], (step.x_measured, step.y_measured))


def test_a_lost_lock_adds_the_prior_motion_variances(scene):
    frames, template, truth = scene(n=6, path=lambda k: (30.0, 20.0), snr=4.0)
    initial = (0.5, 1.5, 0.2)
    tracker = TemplateTracker(
        template, truth[0], process_std=0.05, measurement_std=0.5, initial_std=initial
    )
    for frame in frames:
        tracker.update(frame)
    before = tracker.update(frames[-1]).covariance
    blank = np.full_like(frames[0], 0.0)
    blank[::2] = 1.0  # stripes: no match for the template anywhere
    step = tracker.update(blank)
    assert step.collapsed and not step.reacquired
    f, q, _, _ = tracker.model_matrices()
    prior = np.array(initial) ** 2 * [0, 1, 1]
    expected = f @ before @ f.T + q + np.diag(np.tile(prior, 2))
    np.testing.assert_allclose(step.covariance, expected, rtol=1e-12, atol=1e-12)


def test_window_grows_while_coasting(scene):
    frames, template, truth = scene(n=30, path=lambda k: (30.0, 20.0), snr=4.0)
    blank = [
        f * 0 + np.random.default_rng(k).standard_normal(f.shape) for k, f in enumerate(frames)
    ]
    tracker = TemplateTracker(template, truth[0], process_std=0.05, measurement_std=0.5)
    track = tracker.track(frames[:10] + blank[:8])
    coasted = track[track.coasted]
    assert len(coasted) >= 6
    sizes = coasted.window_w.to_numpy() * coasted.window_h.to_numpy()
    assert np.all(np.diff(sizes) >= 0) and sizes[-1] > sizes[0]


def test_several_templates_equal_separate_trackers(scene):
    frames, t1, truth1 = scene(seed=1, shape=(70, 90))
    rng = np.random.default_rng(7)
    t2 = rng.standard_normal((7, 7))
    frames = [f.copy() for f in frames]
    for k, f in enumerate(frames):
        f[40:47, 60 - k % 5 : 67 - k % 5] += t2
    settings = dict(process_std=0.05, measurement_std=0.5, update_template=0.1)
    multi = TemplateTracker([t1, t2], [truth1[0], (60, 40)], **settings)
    singles = [
        TemplateTracker(t1, truth1[0], **settings),
        TemplateTracker(t2, (60, 40), **settings),
    ]
    table = multi.track(frames)
    assert list(table.columns[:2]) == ["frame", "particle"]
    for p, single in enumerate(singles):
        alone = single.track(frames).drop(columns="frame").reset_index(drop=True)
        mine = table[table.particle == p].drop(columns=["frame", "particle"]).reset_index(drop=True)
        pd.testing.assert_frame_equal(mine, alone)


def test_streaming_equals_batch_and_pickling_resumes_exactly(scene):
    frames, template, truth = scene(path=_leave_and_return)
    settings = dict(process_std=0.05, measurement_std=0.5, update_template=0.2)
    batch = TemplateTracker(template, truth[0], **settings).track(np.stack(frames))
    streaming = TemplateTracker(template, truth[0], **settings)
    rows = [streaming.track(frames[:13]), None]
    copy = pickle.loads(pickle.dumps(streaming))
    assert copy.frame == 13
    rows[1] = streaming.track(frames[13:])
    pd.testing.assert_frame_equal(pd.concat(rows, ignore_index=True), batch)
    resumed = copy.track(frames[13:])
    pd.testing.assert_frame_equal(resumed, rows[1])  # bit-identical continuation
    np.testing.assert_array_equal(copy.templates[0], streaming.templates[0])
    fresh = pickle.loads(pickle.dumps(TemplateTracker(template, truth[0], **settings)))
    pd.testing.assert_frame_equal(fresh.track(frames), batch)


def test_track_columns_and_dtypes(scene):
    frames, template, truth = scene(n=5)
    frames = [np.clip(f * 40 + 128, 0, 255).astype(np.uint8) for f in frames]
    tpl = frames[0][20:29, 10:21].copy()
    table = TemplateTracker(tpl, (10, 20), process_std=0.1).track(frames, progress=False)
    assert list(table.columns) == [
        "frame", "x", "y", "vx", "vy", "score", "window_w", "window_h", "reacquired",
        "x_measured", "y_measured", "coasted",
    ]  # fmt: skip
    assert table.frame.tolist() == list(range(5))
    assert table.reacquired.dtype == bool and table.window_w.dtype.kind == "i"


def test_nan_occlusion_coasts(scene):
    frames, template, truth = scene(n=30, snr=3.0)
    for f in frames[12:16]:
        f[:, :] = np.nan
    tracker = TemplateTracker(template, truth[0], process_std=0.05, measurement_std=0.5)
    track = tracker.track(frames)
    occluded = track[(track.frame >= 12) & (track.frame < 16)]
    assert occluded.coasted.all() and np.isnan(occluded.score).all()
    later = track[track.frame >= 20]
    true_x = np.array([truth[k][0] for k in later.frame])
    assert np.abs(later.x - true_x).max() < 1.5


class TestBadInput:
    template = np.random.default_rng(0).standard_normal((5, 6))

    @pytest.mark.parametrize(
        "kwargs,error,match",
        [
            (dict(gate=0), ValueError, "gate"),
            (dict(collapse=1.0), ValueError, "collapse"),
            (dict(update_template=0.0), ValueError, "update_template"),
            (dict(update_template=1.5), ValueError, "update_template"),
            (dict(initial_std=(1.0, 2.0)), ValueError, "initial_std"),
            (dict(model="jerk"), ValueError, "model"),
            (dict(process_std=-1.0), ValueError, "process_std"),
            (dict(process_std=np.nan), ValueError, "process_std"),
            (dict(measurement_std=0.0), ValueError, "measurement_std"),
            (dict(reacquire_z=-1.0), ValueError, "reacquire_z"),
            (dict(subpixel="yes"), TypeError, "subpixel"),
        ],
    )
    def test_bad_settings(self, kwargs, error, match):
        settings = dict(process_std=0.1) | kwargs
        with pytest.raises(error, match=match):
            TemplateTracker(self.template, (3, 4), **settings)

    def test_bad_templates_and_positions(self):
        with pytest.raises(ValueError, match="constant"):
            TemplateTracker(np.ones((4, 4)), (0, 0), process_std=0.1)
        with pytest.raises(ValueError, match="empty"):
            TemplateTracker(np.ones((0, 4)), (0, 0), process_std=0.1)
        with pytest.raises(ValueError, match="one position per template"):
            TemplateTracker([self.template, self.template], [(0, 0)], process_std=0.1)
        with pytest.raises(TypeError, match="pair"):
            TemplateTracker(self.template, 3, process_std=0.1)
        with pytest.raises(ValueError, match="finite"):
            TemplateTracker(self.template, (np.nan, 0), process_std=0.1)

    def test_bad_frames_leave_the_tracker_unchanged(self):
        tracker = TemplateTracker(self.template, (3, 4), process_std=0.1)
        frame = np.random.default_rng(1).standard_normal((30, 40))
        tracker.update(frame)
        before = pickle.dumps(tracker)
        with pytest.raises(TypeError, match="dtype"):
            tracker.update(frame.astype(np.float32))
        with pytest.raises(ValueError, match="larger than"):
            tracker.update(frame[:3, :3])
        with pytest.raises(ValueError, match="2-D"):
            tracker.update(frame[None])
        bad = frame.copy()
        bad[5, 5] = np.inf
        with pytest.raises(ValueError, match="infinite"):
            tracker.update(bad)
        assert pickle.dumps(tracker) == before
        with pytest.raises(ValueError, match="does not fit"):
            tracker._core.load_state(np.zeros(3))


def test_docstring_example():
    import doctest

    import kalmanfield.template.tracker as tracker

    assert doctest.testmod(tracker).failed == 0


def _reversal(k):
    # +3 px/frame along x, reversed at frame 14 (a bounce the motion model cannot foresee)
    x = 10 + 3 * k if k <= 14 else 52 - 3 * (k - 14)
    return float(x), 20.0


def test_a_reversal_is_found_by_the_held_hypothesis(scene):
    frames, template, truth = scene(n=24, path=_reversal, snr=4.0)
    settings = dict(process_std=0.05, measurement_std=0.5, initial_std=(0.5, 2.0, 0.2))
    rust, _, steps = _rust_and_twin(frames, template, truth[0], settings)
    # frame 15: the old velocity predicts x ≈ 55 (gate ± ~2.5 px), the target is at 49
    turn = steps[15]
    assert not turn.collapsed and abs(turn.x_measured - 49) < 0.5
    assert turn.window[0] <= 49 - 4  # the held window, around the last position (52)
    errors = [abs(s.x - x) for s, (x, _) in zip(steps[15:], truth[15:], strict=True)]
    assert max(errors) < 1.5
    # the first prediction's gate does not reach the target: without the held hypothesis
    # the frame would be coasted on at the old velocity
    f, q, h, r = rust.model_matrices()
    mean, cov = f @ steps[14].state, f @ steps[14].covariance @ f.T + q
    s = h @ cov @ h.T + r
    assert (h @ mean)[0] - 49 > 3 * np.sqrt(s[0, 0]) + 0.5
