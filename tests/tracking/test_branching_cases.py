"""The branching tracker (method page *Tracking*, §3.1–3.3) on hand-built cases, both the Rust
class and its NumPy reference twin: crossing targets, a miss, clutter inside the gate, a target
appearing mid-sequence, non-overlap of the final selection."""

import numpy as np
import pytest

import kalmanfield as kf
from kalmanfield.reference.tracking import branching as reference
from kalmanfield.reference.tracking.branching import chi2_quantile


@pytest.fixture(params=["rust", "reference"])
def tracker_class(request):
    return kf.BranchingTracker if request.param == "rust" else reference.BranchingTracker


def run(tracker_class, frames, **kwargs):
    tracker = tracker_class(
        2, process_std=0.05, measurement_std=0.3, clutter_density=1e-3, **kwargs
    )
    for points in frames:
        tracker.update(np.asarray(points, dtype=float).reshape(-1, 2))
    return tracker.tracks()


def line(start, velocity, frames):
    return [np.add(start, np.multiply(velocity, t)) for t in range(frames)]


def test_chi2_quantile():
    scipy_stats = pytest.importorskip("scipy.stats")
    for beta, dof in [(0.99, 2), (0.95, 8), (0.99, 10)]:
        assert chi2_quantile(beta, dof) == pytest.approx(scipy_stats.chi2.ppf(beta, dof), rel=1e-6)


def test_crossing_targets_keep_their_identity(tracker_class):
    a = line((10.0, 10.0), (2.0, 1.0), 20)
    b = line((10.0, 30.0), (2.0, -1.0), 20)  # they cross at frame 10
    tracks = run(tracker_class, [[p, q] for p, q in zip(a, b)])
    assert tracks.particle.nunique() == 2
    for _, track in tracks.groupby("particle"):
        dy = np.diff(track.sort_values("frame").y.to_numpy())
        assert np.all(dy > 0) or np.all(dy < 0)  # no swap at the crossing
        assert len(track) >= 18


def test_a_missed_detection_is_coasted(tracker_class):
    a = line((5.0, 5.0), (1.5, 0.5), 15)
    frames = [[p] if t != 7 else np.zeros((0, 2)) for t, p in enumerate(a)]
    tracks = run(tracker_class, frames)
    assert tracks.particle.nunique() == 1
    coasted = tracks[tracks.coasted]
    assert list(coasted.frame) == [7]
    assert coasted.x.iloc[0] == pytest.approx(a[7][0], abs=0.5)
    assert coasted.y.iloc[0] == pytest.approx(a[7][1], abs=0.5)


def test_clutter_inside_the_gate_is_not_taken(tracker_class):
    a = line((5.0, 5.0), (1.0, 1.0), 15)
    frames = [[p] for p in a]
    frames[8] = [a[8], a[8] + np.array([1.2, -1.0])]  # a stray point next to the target
    tracks = run(tracker_class, frames)
    assert tracks.particle.nunique() == 1
    row = tracks[tracks.frame == 8].iloc[0]
    assert abs(row.x - a[8][0]) < 0.5 and abs(row.y - a[8][1]) < 0.5


def test_a_target_appearing_mid_sequence_gets_its_own_track(tracker_class):
    a = line((5.0, 5.0), (1.0, 0.0), 25)
    b = line((50.0, 40.0), (-1.0, 0.5), 15)
    frames = [[p] if t < 10 else [p, b[t - 10]] for t, p in enumerate(a)]
    tracks = run(tracker_class, frames)
    assert tracks.particle.nunique() == 2
    starts = sorted(tracks.groupby("particle").frame.min())
    assert starts[0] == 0 and starts[1] >= 10


def test_final_selection_does_not_share_measured_detections(tracker_class):
    rng = np.random.default_rng(0)
    a = line((10.0, 10.0), (1.0, 1.0), 30)
    b = line((40.0, 10.0), (-1.0, 1.0), 30)
    frames = [
        np.vstack([p, q, rng.uniform(0, 60, (3, 2))]) for p, q in zip(a, b)
    ]  # two crossing targets plus clutter
    tracks = run(tracker_class, frames)
    measured = tracks[~tracks.coasted].detection
    assert measured.is_unique
    assert tracks.particle.nunique() >= 2
