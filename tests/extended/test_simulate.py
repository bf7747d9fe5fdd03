"""The scene simulator (method page *Extended objects*, §3.5): SNR, clutter probability and the
motion model's increments, with tolerances of 4 standard errors (stated per test)."""

from __future__ import annotations

import numpy as np
import pytest

import kalmanfield as kf


def test_snr_is_amplitude_over_noise_std():
    s = kf.simulate_scene(
        (48, 48),
        40,
        targets=1,
        snr=3.0,
        p_false=0.0,
        dt=0.1,
        seed=1,
        still_objects=0,
        moving_objects=0,
    )
    inside = s.frames[s.masks[:, 0]]
    outside = s.frames[~s.masks[:, 0]]
    # SE of a mean of n N(·, 1) pixels: 1/√n; of a variance estimate: √(2/n)
    assert abs(inside.mean() - 3.0) < 4 / np.sqrt(inside.size)
    assert abs(outside.mean()) < 4 / np.sqrt(outside.size)
    assert abs(outside.var() - 1.0) < 4 * np.sqrt(2 / outside.size)
    assert s.amplitude == 3.0 and s.noise_std == 1.0


@pytest.mark.parametrize("p_false", [0.1, 0.3])
def test_clutter_frames_appear_with_probability_p_false(p_false):
    n = 3000
    s = kf.simulate_scene(
        (8, 8),
        n,
        targets=0,
        snr=3.0,
        p_false=p_false,
        dt=0.1,
        seed=2,
        still_objects=0,
        moving_objects=0,
    )
    rate = float(np.mean(s.clutter > 0))
    # binomial SE √(p(1 − p)/n): 0.0055 at p = 0.1, 0.0084 at p = 0.3
    assert abs(rate - p_false) < 4 * np.sqrt(p_false * (1 - p_false) / n)
    assert set(np.unique(s.clutter)) <= {0, 3}


def test_motion_increments_follow_the_model():
    n, sigma, dt = 3000, 0.5, 0.1
    s = kf.simulate_scene(
        (8, 8),
        n,
        targets=[kf.Target(process_std=sigma, velocity=(1.0, -1.0))],
        snr=3.0,
        p_false=0.0,
        dt=dt,
        seed=3,
        still_objects=0,
        moving_objects=0,
    )
    t = s.truth
    v = t[["vx", "vy"]].to_numpy()
    x = t[["x", "y"]].to_numpy()
    w = np.diff(v, axis=0)
    # w ~ N(0, σ²): SE of the mean σ/√m, of the variance σ²√(2/m), m = 2(n − 1) values
    m = w.size
    assert abs(w.mean()) < 4 * sigma / np.sqrt(m)
    assert abs(w.var() - sigma**2) < 4 * sigma**2 * np.sqrt(2 / m)
    # the position moves by the previous velocity plus the same increment, times τ (3.7)
    np.testing.assert_allclose(np.diff(x, axis=0), (v[:-1] + w) * dt, atol=1e-12)
    # starts at the frame centre ± N(0, 0.1²)
    assert np.all(np.abs(x[0] - 3.5) < 0.5)


def test_fragments_vanish_with_probability_p_vanish():
    n = 400
    target = kf.Target(fragments=4, p_vanish=0.25, velocity=(0.0, 0.0), process_std=0.0)
    s = kf.simulate_scene(
        (32, 32),
        n,
        targets=[target],
        snr=50.0,
        p_false=0.0,
        dt=1.0,
        seed=4,
        still_objects=0,
        moving_objects=0,
        noise_std=1e-3,
    )
    lit = s.frames[:, s.masks[0, 0]] > 0.5 * 0.7 * s.amplitude
    # pixels of one stripe are lit or dark together; the dark fraction over stripes and frames
    dark = 1.0 - lit.mean()
    gap = 1.0 - lit.any(axis=0).mean()  # gap pixels are never lit
    frac = (dark - gap) / (1 - gap)
    # SE of a proportion over n frames × 4 stripes: √(p(1 − p)/(4n)) ≈ 0.011
    assert abs(frac - 0.25) < 4 * np.sqrt(0.25 * 0.75 / (4 * n))


def test_shapes_and_given_trajectory():
    path = np.column_stack([np.linspace(10, 20, 5), np.full(5, 16.0)])
    s = kf.simulate_scene(
        (32, 32),
        5,
        targets=[kf.Target(shape="disc", size=6.0, trajectory=path)],
        snr=5.0,
        p_false=0.0,
        dt=1.0,
        seed=0,
        still_objects=0,
        moving_objects=0,
    )
    np.testing.assert_allclose(s.truth[["x", "y"]].to_numpy(), path)
    assert s.masks[0, 0].sum() == 29  # pixel centres within radius 3 of (10, 16)
    own = np.zeros((3, 3), bool)
    own[1] = True
    s = kf.simulate_scene(
        (16, 16),
        2,
        targets=[kf.Target(shape=own, velocity=(0, 0), process_std=0)],
        snr=5.0,
        p_false=0.0,
        dt=1.0,
        seed=0,
        still_objects=0,
        moving_objects=0,
    )
    assert s.masks[0, 0].sum() == 3


def test_ar_background_and_bad_input():
    model = kf.ARFieldModel(rho=0.9, order=1, sigma=2.0)
    s = kf.simulate_scene(
        (16, 16),
        3,
        targets=0,
        snr=3.0,
        p_false=0.0,
        dt=1.0,
        seed=0,
        background=kf.ARFieldModel(rho=(0.5, 0.9, 0.9), order=1, sigma=2.0),
        still_objects=0,
        moving_objects=0,
    )
    assert s.frames.std() > 1.5
    with pytest.raises(ValueError):
        kf.simulate_scene((16, 16), 3, snr=-1.0, p_false=0.0, dt=1.0, seed=0)
    with pytest.raises(ValueError):
        kf.simulate_scene((16, 16), 3, snr=1.0, p_false=1.5, dt=1.0, seed=0)
    with pytest.raises(ValueError):
        kf.simulate_scene((16, 16), 3, snr=1.0, p_false=0.1, dt=0.0, seed=0)
    with pytest.raises(TypeError):
        kf.simulate_scene((16, 16), 3, targets=["x"], snr=1.0, p_false=0.1, dt=1.0, seed=0)
    with pytest.raises(TypeError):
        kf.simulate_scene((16, 16), 3, snr=1.0, p_false=0.1, dt=1.0, seed=0, background=model.rho)
    a = kf.simulate_scene((16, 16), 3, snr=1.0, p_false=0.5, dt=1.0, seed=9)
    b = kf.simulate_scene((16, 16), 3, snr=1.0, p_false=0.5, dt=1.0, seed=9)
    np.testing.assert_array_equal(a.frames, b.frames)
