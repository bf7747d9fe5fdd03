"""Change detectors: == the NumPy twin; restart semantics; streaming == run; pickling; the
false-alarm levels of chi2 and cusum within binomial intervals; CUSUM thresholds."""

import pickle

import numpy as np
import pytest
from trajectory_cases import SETTINGS, make

from kalmanfield import ChangeDetector, FuzzyFilter, KalmanFilterCV, _core
from kalmanfield.reference import trajectory as ref

METHODS = ["fuzzy", "chi2", "cusum"]


def model_series(n_series, n, seed, q, q_vel, r, times=None, jumps=None):
    """Samples of the Gaussian model x_n = x_{n-1} + x'_{n-1}τ_n + w_n, x'_n = x'_{n-1} + w'_n,
    z_n = x_n + v_n (variances q², q_vel², r²), plus position jumps `jumps[s] = (n, size)`."""
    rng = np.random.default_rng(seed)
    tau = np.diff(np.arange(n, dtype=float) if times is None else times)
    x = np.zeros((n_series, n))
    v = rng.normal(0, 1, n_series)
    x[:, 0] = rng.normal(0, 5, n_series)
    for k in range(1, n):
        x[:, k] = x[:, k - 1] + v * tau[k - 1] + rng.normal(0, q, n_series)
        v = v + rng.normal(0, q_vel, n_series)
    for s, (k, size) in (jumps or {}).items():
        x[s, k:] += size
    return x + rng.normal(0, r, x.shape)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("rule", ["fuzzy", "kalman"])
@pytest.mark.parametrize("setting", [SETTINGS[0], SETTINGS[1], SETTINGS[4]])
def test_detector_equals_the_twin(method, rule, setting):
    f, spreads = make(rule, setting)
    rng = np.random.default_rng(4)
    n = 60
    z = model_series(4, n, 4, 0.3, 0.05, 1.0, jumps={0: (20, 30.0), 1: (35, -20.0), 3: (10, 12.0)})
    z[2, 7] = np.nan
    z_vel = rng.normal(0, 1, z.shape) if setting[5] is not None else None
    times = np.cumsum(rng.uniform(0.5, 1.5, n))
    found = ChangeDetector(f, method, confidence=0.95, window=4, drift=0.7).run(
        z, times, velocity=z_vel
    )
    assert found.alarm.any()
    for s in range(4):
        zv = None if z_vel is None else z_vel[s]
        pos, vel, alarm, stat = ref.detect(
            spreads, method, 0.95, z[s], times, zv, window=4, drift=0.7
        )
        np.testing.assert_array_equal(found.alarm[s], alarm)
        np.testing.assert_allclose(found.position[s], pos, rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(found.velocity[s], vel, rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(found.statistic[s], stat, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("method", METHODS)
def test_an_alarm_restarts_the_filter(method):
    f = FuzzyFilter(1.0, 0.2, 0.5, 1.0, 0.05)
    z = model_series(1, 80, 7, 0.2, 0.05, 0.5, jumps={0: (40, 15.0)})[0]
    found = ChangeDetector(f, method, confidence=0.99).run(z)
    alarms = found.indices()
    assert 40 in alarms
    n = alarms[list(alarms).index(40)]
    assert found.position[n] == z[n] and found.velocity[n] == 0.0  # a one-sample start
    stop = next((a for a in alarms if a > n), len(z))
    fresh = f.filter(z[n:stop], np.arange(n, stop, dtype=float))
    np.testing.assert_array_equal(found.position[n:stop], fresh.position)


@pytest.mark.parametrize("method", METHODS)
def test_streaming_equals_run_and_pickles(method):
    det = ChangeDetector(KalmanFilterCV(1.0, 0.3, 1.0, 1.0, 0.05), method, confidence=0.9)
    z = model_series(3, 50, 8, 0.3, 0.05, 1.0, jumps={1: (25, 9.0)})
    found = det.run(z)
    for n in range(20):
        x, v, alarm = det.step(z[:, n])
        np.testing.assert_array_equal(x, found.position[:, n])
        np.testing.assert_array_equal(alarm, found.alarm[:, n])
    other = pickle.loads(pickle.dumps(det))
    for n in range(20, 50):
        a, b = det.step(z[:, n]), other.step(z[:, n])
        for u, w in zip(a, b):
            np.testing.assert_array_equal(u, w)
        np.testing.assert_array_equal(a[0], found.position[:, n])
        np.testing.assert_array_equal(a[2], found.alarm[:, n])
    det.reset()
    assert det.step(z[0, 0]) == (found.position[0, 0], found.velocity[0, 0], False)


def test_chi2_false_alarms_per_test_are_binomial():
    # each series holds exactly one test: the diffuse start takes samples 0–1, the first
    # innovation is at sample 2, the window of W = 5 innovations is full at sample 6. Under the
    # model the window sum is χ²_5, so the alarms are Binomial(M, 1 - confidence):
    # M = 20,000, p = 0.1 → mean 2,000, SD √(M p (1-p)) = 42.4; accepted within ±4 SD
    # (a false failure once in 16,000 runs). Irregular times: the exactness holds for any τ.
    m, p = 20_000, 0.1
    times = np.array([0.0, 0.7, 2.0, 2.5, 4.0, 4.2, 5.0])
    z = model_series(m, 7, 11, 0.4, 0.1, 1.5, times=times)
    for cls in (FuzzyFilter, KalmanFilterCV):
        det = ChangeDetector(cls(2.0, 0.4, 1.5, 1.0, 0.1), "chi2", confidence=1 - p, window=5)
        found = det.run(z, times)
        tested = ~np.isnan(found.statistic)
        assert tested[:, 6].all() and not tested[:, :6].any()
        count = found.alarm[:, 6].sum()
        assert abs(count - m * p) < 4 * np.sqrt(m * p * (1 - p)), count


def test_cusum_false_alarms_per_tested_sample():
    # jump-free series of the model; after each alarm the test's Kalman filter restarts on the
    # next sample, so its innovations stay independent N(0, 1) and the alarms are the renewals
    # of the CUSUM's run length (mean 1/(1 - confidence) = 50 tested samples, from the
    # integral equation). Over T tested samples the count is ≈ Binomial(T, 1/50) (run lengths
    # nearly geometric; their variance is a little below the geometric one, so the binomial
    # SD is conservative): T ≈ 398,000 → mean ≈ 7,960, SD ≈ 88; accepted within ±4 SD (±4.4 %).
    p = 0.02
    z = model_series(200, 2000, 12, 0.3, 0.05, 1.0)
    det = ChangeDetector(KalmanFilterCV(1.0, 0.3, 1.0, 1.0, 0.05), "cusum", confidence=1 - p)
    found = det.run(z)
    tested = int((~np.isnan(found.statistic)).sum())
    count = int(found.alarm.sum())
    assert abs(count - tested * p) < 4 * np.sqrt(tested * p * (1 - p)), (count, tested * p)


def test_fuzzy_test_finds_large_jumps_at_once():
    # position jumps of 10 R in 200 series: the alarm falls on the jump sample itself
    jumps = {s: (30 + s % 20, 10.0 * (1 if s % 2 else -1)) for s in range(200)}
    z = model_series(200, 80, 13, 0.1, 0.01, 1.0, jumps=jumps)
    found = ChangeDetector(FuzzyFilter(1.0, 0.1, 1.0, 1.0, 0.01), "fuzzy", confidence=0.9).run(z)
    hits = [found.alarm[s, k] for s, (k, _) in jumps.items()]
    assert np.mean(hits) > 0.95


def test_cusum_threshold_equals_the_twin_and_the_tables():
    # two-sided ARL 465 at h = 5, k = 0.5 (the standard table); the twin uses NumPy's
    # Gauss–Legendre nodes and bisection
    assert _core.cusum_threshold(1 - 1 / 465.4435, 0.5) == pytest.approx(5.0, abs=1e-6)
    for c, k in [(0.9, 0.5), (0.99, 0.25), (0.999, 1.0), (0.99, 2.0)]:
        assert _core.cusum_threshold(c, k) == pytest.approx(ref.cusum_threshold(c, k), rel=1e-8)
    assert _core.cusum_arl(4.0, 0.5) == pytest.approx(ref.cusum_arl(4.0, 0.5), rel=1e-9)


def test_change_points_helpers():
    z = np.r_[np.zeros(20), np.full(20, 30.0)] + np.sin(np.arange(40))
    det = ChangeDetector(FuzzyFilter(1.0, 0.5, 1.0), "fuzzy", confidence=0.99)
    one = det.run(z)
    assert list(one.indices()) == [20]
    many = det.run(np.vstack([z, -z, np.zeros(40)]))
    assert [list(i) for i in many.indices()] == [[20], [20], []]
    frame = many.to_frame()
    assert list(frame.columns) == ["series", "sample"]
    assert frame.values.tolist() == [[0, 20], [1, 20]]
    assert det.threshold == pytest.approx(-np.log(0.01))
    assert "ChangeDetector" in repr(det)
    # defaults: the study's winner, about one false alarm per 1,000 samples
    default = ChangeDetector(FuzzyFilter(1.0, 0.5, 1.0))
    assert default.settings == dict(method="cusum", confidence=0.999, window=5, drift=0.5)
    assert list(default.run(z).indices()) == [20]


def test_plots():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kalmanfield.trajectory import plot_change_points, plot_gain_comparison

    fig = plot_gain_comparison(2, n=10)
    assert len(fig.axes) == 2 and all(len(ax.lines) == 4 for ax in fig.axes)
    plt.close(fig)
    z = np.r_[np.zeros(20), np.full(20, 30.0)]
    found = ChangeDetector(FuzzyFilter(1.0, 0.5, 1.0)).run(z)
    _, ax = plt.subplots()
    assert plot_change_points(z, found, ax=ax) is ax
    assert len(ax.lines) == 3  # samples, estimate, one alarm
    plt.close("all")
    with pytest.raises(ValueError, match="figure"):
        plot_gain_comparison(3)
