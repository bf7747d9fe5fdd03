"""link's data-derived noise levels (method page *Tracking*, §3.6): the variance model of the
second differences, its solution, and the estimates on tracks of known noise."""

import numpy as np
import pytest

from kalmanfield.tracking import noise_levels as nl


def test_second_difference_variances_of_the_motion_model():
    """The coefficients of σ_a², σ_D², σ_m² in Var(z_{t+j} − 2 z_t + z_{t−j}), computed
    independently: positions as linear maps of the per-frame accelerations a_s (held over
    the frame: x_t = Σ_{s<t} a_s (t − s − ½)), diffusion steps and measurement errors, the
    variance the sum of the squared coefficients."""
    for row, j in zip(nl._DESIGN, nl.SCALES):
        n = 2 * j

        def x(t, n=n):
            return np.array([(t - s - 0.5) if s < t else 0.0 for s in range(n)])

        accel = x(n) - 2 * x(j) + x(0)
        walk = np.array([1.0 if j <= s < n else -1.0 for s in range(n)])  # steps into t+1
        noise = np.array([1.0, -2.0, 1.0])
        np.testing.assert_allclose(row, [accel @ accel, walk @ walk, noise @ noise], rtol=1e-14)


@pytest.mark.parametrize("truth", [(0.01, 1.0, 0.04), (0.0, 0.25, 0.09), (0.04, 0.0, 0.25)])
def test_solve_variances_inverts_the_model(truth):
    var = nl._DESIGN @ np.array(truth)
    np.testing.assert_allclose(nl.solve_variances(var), truth, atol=1e-12)


def test_solve_variances_never_negative():
    """Variances that fall with the scale (no motion model gives them) fit as measurement
    noise alone, not as a negative acceleration."""
    got = nl.solve_variances(np.array([2.0, 1.9, 1.8, 1.7]))
    assert (got >= 0).all() and got[2] > 0


def _tracks(seed, accel=0.0, diffusion=0.0, noise=0.0, n=100, frames=60, speed=2.0):
    """n tracks of drift (a random velocity of RMS `speed`) + white acceleration +
    diffusion, measured with noise."""
    rng = np.random.default_rng(seed)
    values, frame, particle = [], [], []
    for p in range(n):
        x = rng.uniform(0, 500, 2)
        v = speed * rng.normal(size=2) / np.sqrt(2)
        for t in range(frames):
            a = rng.normal(0, accel, 2)
            if t:
                x = x + v + a / 2 + rng.normal(0, diffusion, 2)
                v = v + a
            values.append(x + rng.normal(0, noise, 2))
            frame.append(t)
            particle.append(p)
    return np.array(values), np.array(frame), np.array(particle)


FALLBACK = nl.MotionNoise((9.0, 9.0), (9.0, 9.0), (9.0, 9.0), 99.0, 0)


@pytest.mark.parametrize(
    "truth,bounds",
    [
        # (σ_a, σ_D, σ_m) and the accepted ranges. The per-track robust variance of ~56
        # second differences has a relative SD of √(2 · 2.72 / 56) ≈ 0.31 (the MAD's
        # efficiency is 37 %); its 75th percentile over the tracks sits ~0.2 above the
        # truth in variance, ~0.1 in std, with an SE of ~4 % over 100 tracks. A small
        # variance next to a large one (σ_m under diffusion, σ_a under measurement noise)
        # is poorly determined: loose bounds there (measured on four seeds).
        ((0.0, 1.0, 0.2), dict(diffusion=(0.95, 1.2), accel=(0.0, 0.25), noise=(0.1, 0.4))),
        ((0.1, 0.0, 0.5), dict(diffusion=(0.0, 0.35), accel=(0.0, 0.15), noise=(0.45, 0.65))),
        ((0.1, 0.5, 0.3), dict(diffusion=(0.4, 0.7), accel=(0.05, 0.2), noise=(0.25, 0.45))),
    ],
)
def test_estimates_on_tracks_of_known_noise(truth, bounds):
    accel, diffusion, noise = truth
    values, frame, particle = _tracks(0, accel, diffusion, noise)
    est = nl.estimate_motion_noise(values, frame, particle, 2, FALLBACK)
    got = dict(accel=est.process_std, diffusion=est.diffusion_std, noise=est.measurement_std)
    for name, (lo, hi) in bounds.items():
        assert got[name][0] == got[name][1]  # the positions are pooled
        assert lo <= got[name][0] <= hi, name
    # steps: drift of RMS 2 px/frame per vector plus the noise; twice their 99th percentile
    assert 8.0 < est.max_speed < 13.0


def test_features_are_estimated_alone_and_unlinked_rows_ignored():
    values, frame, particle = _tracks(1, diffusion=1.0, noise=0.2)
    rng = np.random.default_rng(2)
    amplitude = 50.0 + rng.normal(0, 3.0, len(values))  # constant + noise: σ_m = 3
    clutter = np.c_[rng.uniform(0, 500, (300, 2)), rng.uniform(0, 100, 300)]
    values = np.vstack([np.c_[values, amplitude], clutter])
    frame = np.r_[frame, rng.integers(0, 60, 300)]
    particle = np.r_[particle, np.full(300, -1)]
    est = nl.estimate_motion_noise(values, frame, particle, 2, nl.pilot_noise(values, frame, 2))
    assert 0.95 <= est.diffusion_std[0] <= 1.2
    assert 2.5 <= est.measurement_std[2] <= 3.6
    assert est.diffusion_std[2] < 0.6 and est.process_std[2] < 0.6


def test_too_few_samples_keep_the_fallback():
    values, frame, particle = _tracks(3, diffusion=1.0, n=2, frames=15)
    assert nl.estimate_motion_noise(values, frame, particle, 2, FALLBACK) is FALLBACK
    particle[:] = -1
    assert nl.estimate_motion_noise(values, frame, particle, 2, FALLBACK) is FALLBACK


def test_pilot_scales_with_the_spacing():
    """L = √(area per detection): 100 detections per frame in 1000 × 1000 give L = 100."""
    rng = np.random.default_rng(4)
    values = rng.uniform(0, 1000, (1000, 2))
    values[:2] = [[0.0, 0.0], [1000.0, 1000.0]]  # the bounding box exactly 1000²
    frame = np.repeat(np.arange(10), 100)
    pilot = nl.pilot_noise(values, frame, 2)
    assert nl.mean_spacing(values, frame, 2) == pytest.approx(100.0)
    assert pilot.diffusion_std == pytest.approx((5.0, 5.0))
    assert pilot.measurement_std == pilot.process_std == pytest.approx((100 / 60, 100 / 60))
    assert pilot.max_speed == pytest.approx(100 / 3)
