"""The exact filter over frames (method page *Sequence filter*, §2.5.1–2.5.2): brute-force
Kalman, twin, Monte Carlo error map, streaming, pickling, missing pixels."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from sequence_cases import brute_force, noisy_sequence

import kalmanfield as kf
from kalmanfield.reference.sequence import sequence_filters as ref

CASES = [
    ((0.7, 0.8, 0.6), (1, 1, 2), 0.5),
    ((0.9, 0.7, 0.85), (2, 2, 1), 1.3),
]


@pytest.mark.parametrize(("rho", "order", "noise_var"), CASES)
def test_optimal_is_the_brute_force_kalman_filter(rho, order, noise_var):
    # 4 frames of 6×5: E[x_t | z_0..t] by dense conditioning on the 120 values
    model = kf.ARFieldModel(rho, order, sigma=1.7)
    _, z = noisy_sequence(model, noise_var, 4, (6, 5), seed=3)
    got = kf.SequenceFilter(model, noise_var, (6, 5), method="optimal").filter(z)
    for t in range(4):
        want, _ = brute_force(model, noise_var, z, t, t)
        np.testing.assert_allclose(got[t], want, atol=1e-10, rtol=0)


@pytest.mark.parametrize("lag", [1, 2, 5])
def test_lag_is_the_brute_force_fixed_lag_smoother(lag):
    model = kf.ARFieldModel((0.85, 0.7, 0.6), (2, 1, 1))
    _, z = noisy_sequence(model, 0.8, 4, (6, 5), seed=4)
    f = kf.SequenceFilter(model, 0.8, (6, 5), lag=lag)
    got = f.filter(z)
    for s in range(4):
        # frame s from the frames up to s + lag (the last ones: all there are)
        want, _ = brute_force(model, 0.8, z, min(s + lag, 3), s)
        np.testing.assert_allclose(got[s], want, atol=1e-10, rtol=0)


def test_rust_kernel_equals_the_numpy_twin():
    rho, order = (0.9, 0.8, 0.6), (2, 1, 2)
    model = kf.ARFieldModel(rho, order)
    _, z = noisy_sequence(model, 0.6, 7, (9, 8), seed=5)
    z[2, 3:5, 1:6] = np.nan  # partly missing frame
    z[4] = np.nan  # a frame with every pixel missing
    for lag in (0, 3):
        got = kf.SequenceFilter(model, 0.6, (9, 8), lag=lag).filter(z)
        want = ref.modal_filter(z, rho, order, 1.0, 0.6, lag=lag)
        np.testing.assert_allclose(got, want, atol=1e-10, rtol=0)
        got_map = kf.SequenceFilter(model, 0.6, (9, 8), lag=lag).error_variance()
        want_map = ref.modal_error_map(rho, order, 1.0, 0.6, (9, 8), lag=lag)
        np.testing.assert_allclose(got_map, want_map, atol=1e-10, rtol=0)


def test_error_map_is_the_dense_posterior_variance_of_a_long_sequence():
    # ρ_t = 0.5: 14 frames reach the steady state to ~1e-9
    model = kf.ARFieldModel((0.5, 0.8, 0.7), (1, 2, 1), sigma=2.0)
    _, z = noisy_sequence(model, 1.5, 14, (5, 4), seed=6)
    _, var = brute_force(model, 1.5, z, 13, 13)
    got = kf.SequenceFilter(model, 1.5, (5, 4)).error_variance()
    np.testing.assert_allclose(got, var, rtol=1e-7)
    _, smoothed = brute_force(model, 1.5, z, 13, 11)
    got = kf.SequenceFilter(model, 1.5, (5, 4), lag=2).error_variance()
    np.testing.assert_allclose(got, smoothed, rtol=1e-7)


def test_error_map_is_the_monte_carlo_mse():
    # 600 sequences of 10 frames (steady after ~8 at ρ_t = 0.4); the squared error of a
    # pixel has SE ≈ √2·v/√600 ≈ 0.058·v, the mean over 30 pixels (correlated) at most that:
    # the map's mean within 4 SE, each pixel within 5 SE.
    model = kf.ARFieldModel((0.4, 0.8, 0.8), (1, 1, 1))
    rng = np.random.default_rng(7)
    f = kf.SequenceFilter(model, 1.0, (6, 5))
    errors = []
    for _ in range(600):
        x = model.sample((10, 6, 5), seed=int(rng.integers(2**32)))
        estimate = f.filter(x + rng.normal(size=x.shape))
        errors.append((estimate[-1] - x[-1]) ** 2)
    mse = np.mean(errors, axis=0)
    v = f.error_variance()
    se = np.sqrt(2 / 600) * v
    assert np.all(np.abs(mse - v) < 5 * se)
    assert abs(mse.mean() - v.mean()) < 4 * se.mean()


@pytest.mark.parametrize("method", ["optimal", "fast"])
def test_streaming_equals_batch_and_pickles_mid_sequence(method):
    model = kf.ARFieldModel((0.9, 0.85, 0.8), (2, 1, 1))
    _, z = noisy_sequence(model, 1.0, 8, (12, 10), seed=8)
    z[5, 2, 3] = np.nan
    f = kf.SequenceFilter(model, 1.0, (12, 10), method=method)
    batch = f.filter(z)
    stream = [f.step(frame) for frame in z[:4]]
    restored = pickle.loads(pickle.dumps(f))
    assert restored.frames_seen == 4
    rest = [f.step(frame) for frame in z[4:]]
    resumed = [restored.step(frame) for frame in z[4:]]
    np.testing.assert_array_equal(np.array(stream + rest), batch)
    np.testing.assert_array_equal(np.array(resumed), np.array(rest))


def test_smoother_streams_pending_frames_and_pickles():
    model = kf.ARFieldModel((0.9, 0.7, 0.7), (1, 1, 1))
    _, z = noisy_sequence(model, 1.0, 6, (5, 5), seed=9)
    f = kf.SequenceFilter(model, 1.0, (5, 5), lag=2)
    out = [f.step(frame) for frame in z[:3]]
    assert out[0] is None and out[1] is None
    g = pickle.loads(pickle.dumps(f))
    out += [f.step(frame) for frame in z[3:]]
    tail = [g.step(frame) for frame in z[3:]]
    np.testing.assert_array_equal(np.array(tail), np.array(out[3:]))
    streamed = np.concatenate([np.array(out[2:]), f.pending()])
    np.testing.assert_array_equal(streamed, f.filter(z))


def test_a_frame_with_every_pixel_missing_is_an_exact_prediction():
    model = kf.ARFieldModel((0.8, 0.7, 0.6), (1, 1, 1))
    _, z = noisy_sequence(model, 0.7, 4, (6, 5), seed=10)
    z[2] = np.nan
    got = kf.SequenceFilter(model, 0.7, (6, 5)).filter(z)
    for t in range(4):
        want, _ = brute_force(model, 0.7, z, t, t)
        np.testing.assert_allclose(got[t], want, atol=1e-10, rtol=0)


def test_partly_missing_pixels_are_filled_by_the_prediction():
    # Monte Carlo over 300 sequences (MSE SE ≈ 8 % of v): with 2 of 30 pixels missing in
    # every frame, the estimate stays within 20 % of the exact filter's MSE where pixels are
    # observed, and at the missing pixels lies between that and the prior variance.
    model = kf.ARFieldModel((0.9, 0.8, 0.8), (1, 1, 1))
    rng = np.random.default_rng(11)
    f = kf.SequenceFilter(model, 1.0, (6, 5))
    errors = []
    for _ in range(300):
        x, z = noisy_sequence(model, 1.0, 8, (6, 5), seed=int(rng.integers(2**32)))
        z[:, 2, 2] = np.nan
        z[:, 4, 1] = np.nan
        errors.append((f.filter(z)[-1] - x[-1]) ** 2)
    mse = np.mean(errors, axis=0)
    v = f.error_variance()
    observed = np.ones((6, 5), dtype=bool)
    observed[2, 2] = observed[4, 1] = False
    assert np.all(np.isfinite(mse))
    assert np.mean(mse[observed]) < 1.2 * np.mean(v[observed])
    assert np.all(mse[~observed] > v[~observed]) and np.all(mse[~observed] < 1.0)


def test_error_map_of_the_white_time_axis_is_the_per_frame_wiener_map():
    model = kf.ARFieldModel((1e-9, 0.9, 0.8), (1, 2, 1))
    got = kf.SequenceFilter(model, 0.5, (7, 6)).error_variance()
    want = kf.wiener_error_map(kf.ARFieldModel((0.9, 0.8), (2, 1)), 0.5, (7, 6))
    np.testing.assert_allclose(got, want, atol=1e-9)


def test_smoothing_approaches_the_non_causal_bound():
    # the non-causal bound per mode: mean over temporal frequency of λS s / (λS + s)
    rho, order, s = (0.9, 0.8, 0.8), (1, 1, 1), 1.0
    model = kf.ARFieldModel(rho, order)
    uy, ux, lam = ref.mode_basis(rho, order, 1.0, 6, 6)
    omega = (np.arange(20000) + 0.5) * np.pi / 20000
    spectrum = (1 - 0.81) / (1 - 1.8 * np.cos(omega) + 0.81)
    signal = lam.ravel()[:, None] * spectrum
    bound = np.mean(signal * s / (signal + s))
    errors = [
        kf.SequenceFilter(model, s, (6, 6), lag=lag).error_variance().mean()
        for lag in (0, 1, 3, 30)
    ]
    assert all(a > b for a, b in zip(errors, errors[1:]))
    assert errors[-1] == pytest.approx(bound, rel=1e-5)  # (the gap shrinks ~geometrically in lag)
    assert errors[0] > 1.2 * bound
