"""Estimates: == the NumPy twin (1e-12), == §4.1's recursion by hand for the first steps,
KalmanFilterCV == textbook Kalman filters (own matrices, FilterPy); streaming == batch,
batched == one series at a time, any thread count; missing samples; irregular times;
pickling mid-series resumes exactly."""

import math
import pickle

import numpy as np
import pytest
from trajectory_cases import SETTINGS, make, random_walks, textbook_kalman

from kalmanfield import FuzzyFilter, KalmanFilterCV
from kalmanfield.reference import trajectory as ref

RULES = ["fuzzy", "kalman"]


def inputs(setting, n_series=13, n=40, seed=0, irregular=None, missing=False):
    z, z_vel, _, _ = random_walks(n_series, n, seed)
    if missing:
        rng = np.random.default_rng(seed + 1)
        z[rng.random(z.shape) < 0.1] = np.nan
        z[0, :2] = np.nan  # a series starting with missing samples
        z_vel[rng.random(z.shape) < 0.1] = np.nan
    rng = np.random.default_rng(seed + 2)
    times = None
    if irregular == "shared":
        times = np.cumsum(rng.uniform(0.3, 2.0, n))
    elif irregular == "per-series":
        times = np.cumsum(rng.uniform(0.3, 2.0, (n_series, n)), axis=1) - 50
    return z, (z_vel if setting[5] is not None else None), times


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("setting", SETTINGS)
@pytest.mark.parametrize("irregular", [None, "shared", "per-series"])
@pytest.mark.parametrize("missing", [False, True])
def test_estimates_equal_the_twin(rule, setting, irregular, missing):
    f, spreads = make(rule, setting)
    z, z_vel, times = inputs(setting, irregular=irregular, missing=missing)
    est = f.filter(z, times, velocity=z_vel)
    pos, vel = ref.filter_batch(spreads, z, times, z_vel)
    np.testing.assert_allclose(est.position, pos, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(est.velocity, vel, rtol=1e-12, atol=1e-12)


def test_first_estimates_by_hand():
    # P = P' = Q = Q' = R = 1, τ = 1, z = (1, 2.5, 2, 4, 5.5): the source's recursion started
    # from the least-squares line through z_0..z_2 (x̄_0 = 4/3 + ... computed below)
    z = [1.0, 2.5, 2.0, 4.0, 5.5]
    slope = (z[2] - z[0]) / 2  # the LS slope of three equally spaced samples
    x_bar = sum(z[:3]) / 3 - slope
    alpha0 = 0.5
    x, v = x_bar + alpha0 * (z[0] - x_bar), slope  # β_0 = 0
    P, Pv = math.sqrt(0.5), 1.0
    expected = []
    for n in range(1, 5):
        xe = x + v
        Qn = P + Pv + 1
        Pn_sq = Qn**2 / (1 + Qn**2)
        Hn = P + 3
        Qvn = Pv + 1
        Pvn_sq = Hn**2 * Qvn**2 / (Hn**2 + Qvn**2)
        alpha, beta = Pn_sq, Pvn_sq / Hn**2
        x, v = xe + alpha * (z[n] - xe), v + beta * (z[n] - xe)
        P, Pv = math.sqrt(Pn_sq), math.sqrt(Pvn_sq)
        expected.append((x, v))
    est = FuzzyFilter(1, 1, 1, 1, 1).filter(z)
    got = np.column_stack([est.position, est.velocity])
    # from the third sample on: the source's recursion exactly
    np.testing.assert_allclose(got[2:], expected[1:], rtol=1e-13)
    # the first two samples use the samples seen so far: z_0 alone, then the line z_0 → z_1
    assert got[0] == pytest.approx([1.0, 0.0], abs=1e-15)
    assert got[1] == pytest.approx([2.5, 1.5], abs=1e-14)


@pytest.mark.parametrize("setting", SETTINGS)
@pytest.mark.parametrize("irregular", [None, "shared"])
def test_kalman_equals_a_textbook_filter(setting, irregular):
    P, Q, R, P_vel, Q_vel, R_vel = setting
    z, z_vel, times = inputs(setting, n_series=3, irregular=irregular)
    t = np.arange(z.shape[1], dtype=float) if times is None else times
    est = KalmanFilterCV(*setting).filter(z, times, velocity=z_vel)
    has_velocity = P_vel > 0 or Q_vel > 0 or R_vel is not None
    for s in range(3):
        x0, v0 = ref.least_squares_start(has_velocity, t[:3], z[s, :3])
        zv = None if z_vel is None else z_vel[s]
        book = textbook_kalman(z[s], t, x0, v0, P, Q, R, P_vel, Q_vel, zv, R_vel)
        np.testing.assert_allclose(est.position[s, 2:], book[2:, 0], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(est.velocity[s, 2:], book[2:, 1], rtol=1e-10, atol=1e-10)


def test_kalman_equals_filterpy():
    filterpy = pytest.importorskip("filterpy.kalman")
    P, Q, R, P_vel, Q_vel = 2.0, 0.3, 1.0, 1.5, 0.1
    z, _, _ = inputs(SETTINGS[1], n_series=2)
    est = KalmanFilterCV(P, Q, R, P_vel, Q_vel).filter(z)
    for s in range(2):
        kf = filterpy.KalmanFilter(dim_x=2, dim_z=1)
        kf.x = np.array(ref.least_squares_start(True, [0, 1, 2], z[s, :3]))
        kf.F = np.array([[1.0, 1.0], [0.0, 1.0]])
        kf.H = np.array([[1.0, 0.0]])
        kf.P = np.diag([P**2, P_vel**2])
        kf.R = np.array([[R**2]])
        kf.Q = np.diag([Q**2, Q_vel**2])
        out = []
        for n, zn in enumerate(z[s]):
            if n:
                kf.predict()
            kf.update(zn)
            out.append(np.array(kf.x).ravel())
        out = np.array(out)
        np.testing.assert_allclose(est.position[s, 2:], out[2:, 0], rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(est.velocity[s, 2:], out[2:, 1], rtol=1e-10, atol=1e-10)


@pytest.mark.parametrize("rule", RULES)
@pytest.mark.parametrize("setting", [SETTINGS[1], SETTINGS[4]])
@pytest.mark.parametrize("missing", [False, True])
def test_streaming_batched_and_threads_agree_bit_for_bit(rule, setting, missing):
    f, _ = make(rule, setting)
    z, z_vel, times = inputs(setting, n_series=21, irregular="shared", missing=missing)
    batch = f.filter(z, times, velocity=z_vel)
    for threads in (1, 3):
        again = f.filter(z, times, velocity=z_vel, threads=threads)
        np.testing.assert_array_equal(again.position, batch.position)
    for s in (0, 7, 20):  # one series at a time
        one = f.filter(z[s], times, velocity=None if z_vel is None else z_vel[s])
        np.testing.assert_array_equal(one.position, batch.position[s])
        np.testing.assert_array_equal(one.velocity, batch.velocity[s])
    # streaming: all series at once, then one series as numbers
    f.reset()
    for n in range(z.shape[1]):
        x, v = f.step(z[:, n], times[n], velocity=None if z_vel is None else z_vel[:, n])
        np.testing.assert_array_equal(x, batch.position[:, n])
        np.testing.assert_array_equal(v, batch.velocity[:, n])
    f.reset()
    for n in range(z.shape[1]):
        x, v = f.step(z[5, n], times[n], velocity=None if z_vel is None else z_vel[5, n])
        assert isinstance(x, float)
        np.testing.assert_array_equal([x, v], [batch.position[5, n], batch.velocity[5, n]])


@pytest.mark.parametrize("rule", RULES)
def test_pickling_mid_series_resumes_exactly(rule):
    f, _ = make(rule, SETTINGS[4])
    z, z_vel, times = inputs(SETTINGS[4], n_series=4, missing=True)
    for n in range(17):
        f.step(z[:, n], velocity=z_vel[:, n])
    g = pickle.loads(pickle.dumps(f))
    for n in range(17, z.shape[1]):
        a = f.step(z[:, n], velocity=z_vel[:, n])
        b = g.step(z[:, n], velocity=z_vel[:, n])
        np.testing.assert_array_equal(a, b)
    fresh = pickle.loads(pickle.dumps(make(rule, SETTINGS[1])[0]))
    assert fresh.step(1.0) == (1.0, 0.0)


def test_missing_samples_are_predicted():
    f = FuzzyFilter(1.0, 0.5, 1.0, 1.0, 0.2)
    z = np.array([np.nan, np.nan, 1.0, 2.0, 3.5, np.nan, np.nan, 5.0, 6.0])
    est = f.filter(z)
    assert np.isnan(est.position[:2]).all() and np.isnan(est.velocity[:2]).all()
    assert est.position[2] == 1.0  # a segment starts at the first observed sample
    for n in (5, 6):
        assert est.position[n] == est.position[n - 1] + est.velocity[n - 1]
        assert est.velocity[n] == est.velocity[n - 1]
    # the leading gap is no sample of the segment: same as the series without it
    np.testing.assert_array_equal(f.filter(z[2:], np.arange(2.0, 9.0)).position, est.position[2:])


def test_irregular_times_scale_like_the_model():
    # halving every time step with Q, Q' rescaled to the same noise per unit of time is not the
    # same model; but multiplying the times by c and the velocity spreads by 1/c is: x' τ and
    # P'τ, Q'τ are unchanged, so positions agree and velocities scale by 1/c
    z, _, _ = inputs(SETTINGS[1], n_series=3)
    t = np.cumsum(np.random.default_rng(5).uniform(0.5, 1.5, z.shape[1]))
    for cls in (FuzzyFilter, KalmanFilterCV):
        a = cls(1.0, 0.5, 1.0, 0.8, 0.2).filter(z, t)
        b = cls(1.0, 0.5, 1.0, 0.4, 0.1).filter(z, 2 * t)
        np.testing.assert_allclose(b.position, a.position, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(2 * b.velocity, a.velocity, rtol=1e-10, atol=1e-10)


def test_estimates_follow_a_noisy_line():
    # the steady filter is unbiased on a straight line: errors average out
    rng = np.random.default_rng(3)
    t = np.arange(200.0)
    z = 3 + 0.5 * t + rng.normal(0, 1, (400, 200))
    for cls in (FuzzyFilter, KalmanFilterCV):
        est = cls(1.0, 0.1, 1.0, 1.0, 0.01).filter(z)
        err = est.position[:, 50:] - (3 + 0.5 * t[50:])
        # the 400 series are independent: the SE of the grand mean is the spread of the series
        # means over √400; an unbiased filter stays within 5 SE
        se = err.mean(axis=1).std(ddof=1) / np.sqrt(400)
        assert abs(err.mean()) < 5 * se
        verr = est.velocity[:, 50:] - 0.5
        assert abs(verr.mean()) < 5 * verr.mean(axis=1).std(ddof=1) / np.sqrt(400)
