"""Seeded point-target scenario for the branching tracker (method page *Tracking*, §3.3) and its
anchors.

Pure NumPy (pandas only to hand back tables), importable by the benches and the tests::

    from tracking_scenario import Scenario, make_scenario
    sc = make_scenario(seed=1)                 # the issue's anchor scenario
    sc.detections                              # DataFrame frame, x, y, truth (-1 = clutter)
    sc.frames()                                # list of (m, 2) arrays, one per frame
    sc.truth                                   # DataFrame frame, id, x, y, vx, vy

The anchor scenario (defaults): 100 frames of 256 × 256 px, 20 targets present in every frame,
initial speed 2 px/frame in a uniform direction, a piecewise-constant white random acceleration
of std ``accel_std`` = 0.1 px/frame² per axis (the discrete white-noise-acceleration model of
§3.1 with ν = 1: x += v τ + a τ²/2, v += a τ), specular reflection at the borders
(position mirrored into [0, size], that velocity component negated), detection probability
0.9, Gaussian position noise σ = 0.5 px on the detected positions, and a Poisson-free
``n_clutter`` = 50 uniform clutter points per frame (exactly n_clutter, uniform over the
frame). Detections of one frame are shuffled so their order says nothing about their origin;
measured positions are not clipped to the frame.

Optional births/deaths: with ``lifetime=(lo, hi)`` each target lives a uniform random number of
frames in [lo, hi] starting at a uniform random frame, and ``n_targets`` is the number of
tracks over the whole run (not at one time).

Scoring convention of the benches: ground truth = ``truth`` (true positions, all frames a
target exists, detected or not); a hypothesis matches within 3 px (see ``bench_tracking.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class ScenarioConfig:
    """Parameters of the generator; the defaults are the issue's anchor scenario."""

    n_frames: int = 100
    size: float = 256.0
    n_targets: int = 20
    speed: float = 2.0
    accel_std: float = 0.1
    p_detect: float = 0.9
    pos_std: float = 0.5
    n_clutter: int = 50
    dt: float = 1.0
    margin: float = 5.0
    lifetime: tuple[int, int] | None = None


@dataclass
class Scenario:
    """One realisation: the configuration, the truth table and the detection table."""

    config: ScenarioConfig
    seed: int
    truth: pd.DataFrame
    detections: pd.DataFrame
    times: np.ndarray = field(repr=False)

    def frames(self) -> list[np.ndarray]:
        """Detections as a list of (m, 2) float arrays (x, y), one per frame, in table order."""
        out = []
        det = self.detections
        for f in range(self.config.n_frames):
            sel = det[det.frame == f]
            out.append(sel[["x", "y"]].to_numpy(dtype=float))
        return out

    @property
    def clutter_density(self) -> float:
        """True clutter density, points per px² per frame."""
        return self.config.n_clutter / self.config.size**2


def _reflect(pos: np.ndarray, vel: np.ndarray, size: float) -> None:
    """Specular reflection into [0, size] in place (repeated for very fast targets)."""
    for _ in range(4):
        lo = pos < 0.0
        pos[lo] = -pos[lo]
        vel[lo] = -vel[lo]
        hi = pos > size
        pos[hi] = 2.0 * size - pos[hi]
        vel[hi] = -vel[hi]
        if not (lo.any() or hi.any()):
            break


def make_scenario(seed: int = 0, config: ScenarioConfig | None = None, **overrides) -> Scenario:
    """Generate one scenario; ``overrides`` replace fields of ``config`` (or of the defaults).

    Everything is drawn from ``np.random.default_rng(seed)`` in a fixed order, so a seed and a
    configuration give the same scenario on every machine.
    """
    cfg = config or ScenarioConfig()
    if overrides:
        cfg = ScenarioConfig(**{**cfg.__dict__, **overrides})
    rng = np.random.default_rng(seed)
    n, T, dt, size = cfg.n_targets, cfg.n_frames, cfg.dt, cfg.size

    pos = rng.uniform(cfg.margin, size - cfg.margin, size=(n, 2))
    ang = rng.uniform(0.0, 2.0 * np.pi, size=n)
    vel = cfg.speed * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    if cfg.lifetime is None:
        start = np.zeros(n, dtype=int)
        stop = np.full(n, T, dtype=int)
    else:
        lo, hi = cfg.lifetime
        life = rng.integers(lo, hi + 1, size=n)
        start = rng.integers(0, max(1, T - lo + 1), size=n)
        stop = np.minimum(start + life, T)

    truth_rows = []
    det_rows = []
    for f in range(T):
        if f > 0:
            acc = rng.normal(0.0, cfg.accel_std, size=(n, 2))
            pos = pos + vel * dt + 0.5 * acc * dt**2
            vel = vel + acc * dt
            _reflect(pos, vel, size)
        alive = (start <= f) & (f < stop)
        detected = rng.random(n) < cfg.p_detect
        noise = rng.normal(0.0, cfg.pos_std, size=(n, 2))
        clutter = rng.uniform(0.0, size, size=(cfg.n_clutter, 2))
        ids = np.flatnonzero(alive)
        for i in ids:
            truth_rows.append((f, i, pos[i, 0], pos[i, 1], vel[i, 0], vel[i, 1]))
        d_ids = np.flatnonzero(alive & detected)
        meas = pos[d_ids] + noise[d_ids]
        xy = np.concatenate([meas, clutter])
        tid = np.concatenate([d_ids, np.full(cfg.n_clutter, -1)])
        order = rng.permutation(len(xy))
        for j in order:
            det_rows.append((f, xy[j, 0], xy[j, 1], int(tid[j])))

    truth = pd.DataFrame(truth_rows, columns=["frame", "id", "x", "y", "vx", "vy"])
    truth = truth.astype({"frame": int, "id": int})
    det = pd.DataFrame(det_rows, columns=["frame", "x", "y", "truth"])
    det = det.astype({"frame": int, "truth": int})
    return Scenario(cfg, seed, truth, det, times=np.arange(T) * dt)


if __name__ == "__main__":
    sc = make_scenario(1)
    print(sc.config)
    print(sc.truth.head())
    print(sc.detections.groupby("frame").size().describe())
