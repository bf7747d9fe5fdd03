"""Seeded Brownian + directed particle scenario (trackpy's home ground) for ``kalmanfield.link``
and its scores.

Pure NumPy (pandas only to hand back tables), importable by the benches and the tests::

    from brownian_scenario import make_brownian, pair_accuracy
    sc = make_brownian(seed=1)                 # 40 Brownian + 6 directed particles, no clutter
    sc.detections                              # DataFrame frame, x, y, truth (-1 = clutter)
    pair_accuracy(sc, linked.particle)         # consecutive pairs linked right, per kind

The scene (defaults): 100 frames of 256 × 256 px; 40 Brownian particles, steps N(0, 1 px²) per
axis and frame; 6 directed particles at 4 px/frame in a uniform direction with a white random
acceleration of 0.05 px/frame² per axis, reflected at the borders (position mirrored, that
velocity component negated; Brownian particles are mirrored too); Gaussian localisation noise
σ = 0.1 px; every particle detected (``p_detect`` = 1) and no clutter. The clutter variant:
``p_detect=0.9, n_clutter=50`` uniform points per frame. Detections of a frame are shuffled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from tracking_scenario import _reflect  # the anchor scenario's borders


@dataclass
class BrownianScenario:
    """One realisation: the truth table, the detection table and the number of Brownian
    particles (ids 0..n_brownian−1; the directed ones follow)."""

    truth: pd.DataFrame
    detections: pd.DataFrame
    n_brownian: int


def make_brownian(
    seed: int = 0,
    *,
    n_brownian: int = 40,
    n_directed: int = 6,
    step_std: float = 1.0,
    speed: float = 4.0,
    accel_std: float = 0.05,
    size: float = 256.0,
    n_frames: int = 100,
    pos_std: float = 0.1,
    p_detect: float = 1.0,
    n_clutter: int = 0,
) -> BrownianScenario:
    """Generate one scene; everything is drawn from ``np.random.default_rng(seed)`` in a fixed
    order, so a seed and the arguments give the same scene on every machine."""
    rng = np.random.default_rng(seed)
    n = n_brownian + n_directed
    pos = rng.uniform(5.0, size - 5.0, size=(n, 2))
    ang = rng.uniform(0.0, 2.0 * np.pi, n_directed)
    vel = np.zeros((n, 2))
    vel[n_brownian:] = speed * np.c_[np.cos(ang), np.sin(ang)]
    truth, det = [], []
    for f in range(n_frames):
        if f:
            step = np.zeros((n, 2))
            step[:n_brownian] = rng.normal(0.0, step_std, (n_brownian, 2))
            acc = rng.normal(0.0, accel_std, (n_directed, 2))
            step[n_brownian:] = vel[n_brownian:] + acc / 2
            vel[n_brownian:] += acc
            pos = pos + step
            _reflect(pos, vel, size)
        detected = rng.random(n) < p_detect
        noise = rng.normal(0.0, pos_std, (n, 2))
        clutter = rng.uniform(0.0, size, (n_clutter, 2))
        truth.extend((f, i, pos[i, 0], pos[i, 1]) for i in range(n))
        ids = np.flatnonzero(detected)
        xy = np.concatenate([pos[ids] + noise[ids], clutter])
        tid = np.concatenate([ids, np.full(n_clutter, -1)])
        det.extend((f, xy[j, 0], xy[j, 1], int(tid[j])) for j in rng.permutation(len(xy)))
    truth_df = pd.DataFrame(truth, columns=["frame", "id", "x", "y"])
    det_df = pd.DataFrame(det, columns=["frame", "x", "y", "truth"])
    return BrownianScenario(truth_df, det_df, n_brownian)


def pair_accuracy(sc: BrownianScenario, particle: pd.Series) -> tuple[float, float]:
    """(Brownian, directed): the share of consecutive detections of a true particle (in its own
    detection order, so a missed frame is skipped) that carry the same particle label;
    `particle` is indexed like ``sc.detections`` (rows it lacks are unlinked)."""
    d = sc.detections.assign(p=particle.reindex(sc.detections.index).fillna(-1).to_numpy())
    d = d[d.truth >= 0].sort_values(["truth", "frame"])
    same = d.truth.to_numpy()[1:] == d.truth.to_numpy()[:-1]
    p = d.p.to_numpy()
    ok = same & (p[1:] == p[:-1]) & (p[1:] >= 0)
    directed = d.truth.to_numpy()[1:] >= sc.n_brownian

    def share(mask: np.ndarray) -> float:
        return float(ok[mask].mean()) if mask.any() else float("nan")

    return share(same & ~directed), share(same & directed)


def link_precision(sc: BrownianScenario, particle: pd.Series) -> float:
    """The share of consecutive detections of an output track that are consecutive detections
    of one true particle (clutter joined to a track counts against it)."""
    d = sc.detections.assign(p=particle.reindex(sc.detections.index).fillna(-1).to_numpy())
    d = d[d.p >= 0].sort_values(["p", "frame"])
    same = d.p.to_numpy()[1:] == d.p.to_numpy()[:-1]
    t = d.truth.to_numpy()
    ok = same & (t[1:] == t[:-1]) & (t[1:] >= 0)
    return float(ok[same].mean()) if same.any() else float("nan")
