"""The noise levels of the motion model estimated from a detection table: the data-derived
defaults of :func:`~kalmanfield.link` (method page *Tracking*, §3.6).

A pilot configuration scaled by the spacing of the detections links a first time; the
measurement noise, the random acceleration and the diffusion are then fitted to robust
variances of the second differences at four scales along the pilot's tracks, and the
largest speed to their steps.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["MotionNoise", "estimate_motion_noise", "pilot_noise"]

#: second differences the estimate needs (fewer: the pilot's values stay)
MIN_SAMPLES = 30
#: the largest speed is this multiple of the 99th percentile of the tracks' steps
SPEED_MARGIN = 2.0
#: a sixth of the measurement variance is at least this share of the second differences'
#: variance (the lag-2 autocovariance that measures it is small and noisy when the motion
#: noise dominates; the floor keeps the estimate positive)
MEASUREMENT_FLOOR = 0.01
#: σ of a normal law = this times its median absolute deviation
MAD_TO_STD = 1.482602218505602


@dataclass(frozen=True)
class MotionNoise:
    """Noise levels per column (positions, then features), per frame step.

    Attributes
    ----------
    measurement_std, process_std, diffusion_std : tuple of float
        σ_m, σ_a (white acceleration) and σ_D (diffusion) of each column.
    max_speed : float
        The largest speed of a start (positions per frame step).
    n_samples : int
        Second differences behind the estimate (0 for a pilot).
    """

    measurement_std: tuple[float, ...]
    process_std: tuple[float, ...]
    diffusion_std: tuple[float, ...]
    max_speed: float
    n_samples: int


def mean_spacing(values: np.ndarray, frame_numbers: np.ndarray, n_spatial: int) -> float:
    """√(area per detection): the side of the bounding box of the positions (each side at
    least 1) per detection of a mean frame, to the power 1/n_spatial."""
    n_frames = int(frame_numbers.max()) - int(frame_numbers.min()) + 1
    per_frame = max(len(values) / n_frames, 1.0)
    sides = np.maximum(np.ptp(values[:, :n_spatial], axis=0), 1.0)
    return float(np.exp(np.log(sides).sum() / n_spatial) / per_frame ** (1.0 / n_spatial))


def pilot_noise(values: np.ndarray, frame_numbers: np.ndarray, n_spatial: int) -> MotionNoise:
    """The pilot's noise levels, scaled by the mean spacing L of the detections: positions
    σ_m = σ_a = L/60, σ_D = L/20, largest speed L/3 (a target that moves more than a third
    of the spacing per frame cannot be told from its neighbours); features σ_m = their robust
    spread over the table, σ_a = σ_D = 0 (they barely gate the pilot)."""
    spacing = mean_spacing(values, frame_numbers, n_spatial)
    k = values.shape[1]
    spread = [robust_std(values[:, q]) for q in range(n_spatial, k)]
    spread = [s if s > 0 else 1.0 for s in spread]
    return MotionNoise(
        measurement_std=(spacing / 60,) * n_spatial + tuple(spread),
        process_std=(spacing / 60,) * n_spatial + (0.0,) * (k - n_spatial),
        diffusion_std=(spacing / 20,) * n_spatial + (0.0,) * (k - n_spatial),
        max_speed=spacing / 3,
        n_samples=0,
    )


def robust_var(x: np.ndarray) -> float:
    """The variance of a normal law with the median absolute deviation of `x`."""
    if not len(x):
        return 0.0
    return float((MAD_TO_STD * np.median(np.abs(x - np.median(x)))) ** 2)


def robust_std(x: np.ndarray) -> float:
    """√ :func:`robust_var`."""
    return float(np.sqrt(robust_var(x)))


def robust_cov(u: np.ndarray, v: np.ndarray) -> float:
    """Cov(u, v) = (Var(u + v) − Var(u − v)) / 4, each variance robust."""
    return (robust_var(u + v) - robust_var(u - v)) / 4.0


def runs(frame_numbers: np.ndarray, particle: np.ndarray, min_length: int) -> list[np.ndarray]:
    """Row indices of every run of consecutive frames of one particle (frame order), at
    least `min_length` rows long."""
    order = np.lexsort((frame_numbers, particle))
    f, p = frame_numbers[order], particle[order]
    breaks = np.flatnonzero((np.diff(p) != 0) | (np.diff(f) != 1)) + 1
    return [r for r in np.split(order, breaks) if len(r) >= min_length]


#: the scales j of the second differences z_{t+j} − 2 z_t + z_{t−j}
SCALES = (1, 2, 3, 4)
#: rows: scale j; columns: the coefficients of σ_a², σ_D², σ_m² in the variance of the
#: second difference at scale j (white acceleration held over each frame, diffusion,
#: measurement noise): 2 (j³/3 − j/12), 2j, 6
_DESIGN = np.array([[2 * (j**3 / 3 - j / 12), 2.0 * j, 6.0] for j in SCALES])


def _second_difference(v: np.ndarray, j: int) -> np.ndarray:
    """z_{t+j} − 2 z_t + z_{t−j} along the rows of `v`, all columns in one vector."""
    return (v[2 * j :] - 2 * v[j:-j] + v[: -2 * j]).ravel()


def second_difference_variances(runs_values: list[np.ndarray]) -> np.ndarray:
    """Robust variances of the second differences at every scale of :data:`SCALES`, pooled
    over the columns of each run (an (n, c) array): the 75th percentile over the runs of at
    least 16 frames (a population of diffusing and directed particles is covered by its
    most diffusive three quarters; the tracker may gate wide, not narrow), or over all runs
    pooled when fewer than 5 are that long."""
    long_runs = [v for v in runs_values if len(v) >= 16]
    out = np.empty(len(SCALES))
    for s, j in enumerate(SCALES):
        if len(long_runs) >= 5:
            out[s] = np.quantile([robust_var(_second_difference(v, j)) for v in long_runs], 0.75)
        else:
            pooled = [_second_difference(v, j) for v in runs_values if len(v) > 2 * j]
            out[s] = robust_var(np.concatenate(pooled))
    return out


def solve_variances(var: np.ndarray) -> np.ndarray:
    """(σ_a², σ_D², σ_m²) ≥ 0 whose model variances of :data:`_DESIGN` fit `var` best in
    relative terms (least squares of (model − var) / var): every subset of the three may be
    zero, the best fit wins."""
    scale = np.where(var > 0, var, 1.0)
    a, b = _DESIGN / scale[:, None], var / scale
    best, best_res = np.zeros(3), float(np.sum(b**2))
    for free in itertools.chain.from_iterable(
        itertools.combinations(range(3), n) for n in (1, 2, 3)
    ):
        cols = list(free)
        sol, *_ = np.linalg.lstsq(a[:, cols], b, rcond=None)
        if (sol < 0).any():
            continue
        x = np.zeros(3)
        x[cols] = sol
        res = float(np.sum((a @ x - b) ** 2))
        if res < best_res * (1 - 1e-12):
            best, best_res = x, res
    return best


def estimate_motion_noise(
    values: np.ndarray,
    frame_numbers: np.ndarray,
    particle: np.ndarray,
    n_spatial: int,
    fallback: MotionNoise,
) -> MotionNoise:
    """The noise levels of linked detections (`particle` ≥ 0; the others are ignored).

    Along every run of at least 9 consecutive frames of a track, the second differences
    z_{t+j} − 2 z_t + z_{t−j} at scales j = 1…4 have, under drift + diffusion + white
    acceleration + measurement noise, the variances 2 (j³/3 − j/12) σ_a² + 2j σ_D² + 6 σ_m²
    (the drift cancels); their robust variances (:func:`second_difference_variances`, the
    positions pooled, each feature alone) are fitted by the three variances, none negative.
    The largest speed is twice the 99th percentile of the steps between consecutive frames.
    With fewer than 30 runs' worth of second differences the `fallback` stays.
    """
    keep = particle >= 0
    rows = np.flatnonzero(keep)
    segments = [rows[r] for r in runs(frame_numbers[keep], particle[keep], 2 * SCALES[-1] + 1)]
    n = sum(len(r) - 2 for r in segments)
    if n < MIN_SAMPLES:
        return fallback
    k = values.shape[1]
    groups = [list(range(n_spatial))] + [[q] for q in range(n_spatial, k)]
    sigma = {
        name: list(getattr(fallback, name))
        for name in ("process_std", "diffusion_std", "measurement_std")
    }
    for cols in groups:
        var = second_difference_variances([values[r][:, cols] for r in segments])
        if var[0] <= 0:  # a constant column: keep the fallback
            continue
        var_a, var_d, var_m = solve_variances(var)
        var_m = max(var_m, MEASUREMENT_FLOOR * var[0] / 6.0)
        for name, v in zip(sigma, (var_a, var_d, var_m)):
            for q in cols:
                sigma[name][q] = float(np.sqrt(v))
    steps = np.concatenate([np.diff(values[r][:, :n_spatial], axis=0) for r in segments])
    speed = float(np.quantile(np.linalg.norm(steps, axis=1), 0.99))
    return MotionNoise(
        measurement_std=tuple(sigma["measurement_std"]),
        process_std=tuple(sigma["process_std"]),
        diffusion_std=tuple(sigma["diffusion_std"]),
        max_speed=SPEED_MARGIN * speed if speed > 0 else fallback.max_speed,
        n_samples=int(n),
    )
