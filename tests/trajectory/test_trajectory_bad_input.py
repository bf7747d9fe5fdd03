"""Bad input gets a clear ValueError/TypeError (never a panic or a silent NaN)."""

import pickle

import numpy as np
import pytest

from kalmanfield import ChangeDetector, FuzzyFilter, KalmanFilterCV, effective_memory

CLASSES = [FuzzyFilter, KalmanFilterCV]


@pytest.mark.parametrize("cls", CLASSES)
@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(P=0.0), "P must be positive"),
        (dict(Q=-1.0), "Q must be positive"),
        (dict(R=np.nan), "R must be positive"),
        (dict(R=np.inf), "R must be positive"),
        (dict(P=1e200), "at most"),
        (dict(P_vel=-0.1), "P_vel must be non-negative"),
        (dict(Q_vel=np.inf), "Q_vel must be non-negative"),
        (dict(R_vel=0.0), "R_vel must be positive"),
    ],
)
def test_bad_spreads(cls, kwargs, match):
    args = dict(P=1.0, Q=1.0, R=1.0) | kwargs
    with pytest.raises(ValueError, match=match):
        cls(**args)


@pytest.mark.parametrize("cls", CLASSES)
def test_non_numeric_spreads(cls):
    for bad in ("1", True, None, [1.0]):
        with pytest.raises(TypeError):
            cls(bad, 1.0, 1.0)


@pytest.mark.parametrize("cls", CLASSES)
@pytest.mark.parametrize(
    "z, times, error, match",
    [
        ([], None, ValueError, "no sample"),
        (np.empty((3, 0)), None, ValueError, "no sample"),
        (np.empty((0, 4)), None, ValueError, "no sample"),
        ([[1.0, 2.0], [1.0]], None, ValueError, "ragged"),
        (
            np.array([np.array([1.0, 2.0]), np.array([1.0])], dtype=object),
            None,
            ValueError,
            "ragged",
        ),
        (np.ones((2, 2, 2)), None, ValueError, "1-D"),
        (5.0, None, ValueError, "1-D"),
        (["a", "b"], None, TypeError, "real numbers"),
        ([1.0, np.inf, 2.0], None, ValueError, "NaN .missing. or within"),
        ([1.0, 1e200], None, ValueError, "within"),
        ([1.0, 2.0, 3.0], [0.0, 1.0, 1.0], ValueError, "increase strictly"),
        ([1.0, 2.0, 3.0], [0.0, 2.0, 1.0], ValueError, "increase strictly"),
        ([1.0, 2.0, 3.0], [0.0, np.nan, 2.0], ValueError, "finite"),
        ([1.0, 2.0, 3.0], [0.0, 1.0], ValueError, "shape"),
        ([[1.0, 2.0], [3.0, 4.0]], [[0.0, 1.0], [1.0, 0.5]], ValueError, "increase strictly"),
        ([[1.0, 2.0], [3.0, 4.0]], [[0.0, 1.0, 2.0]], ValueError, "shape"),
    ],
)
def test_bad_samples_and_times(cls, z, times, error, match):
    f = cls(1.0, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(error, match=match):
        f.filter(z, times)
    with pytest.raises(error, match=match):
        ChangeDetector(f, "chi2").run(z, times)


def test_velocity_samples_go_with_r_vel():
    with pytest.raises(ValueError, match="velocity="):
        FuzzyFilter(1, 1, 1, 1, 1, R_vel=1.0).filter([1.0, 2.0])
    with pytest.raises(ValueError, match="R_vel"):
        FuzzyFilter(1, 1, 1, 1, 1).filter([1.0, 2.0], velocity=[0.0, 1.0])
    with pytest.raises(ValueError, match="shape"):
        FuzzyFilter(1, 1, 1, 1, 1, R_vel=1.0).filter([1.0, 2.0], velocity=[0.0])
    with pytest.raises(ValueError, match="velocity="):
        FuzzyFilter(1, 1, 1, 1, 1, R_vel=1.0).step(1.0)
    with pytest.raises(ValueError, match="R_vel"):
        ChangeDetector(FuzzyFilter(1, 1, 1)).step(1.0, velocity=1.0)


def test_overflowing_time_steps_are_errors():
    f = FuzzyFilter(1e100, 1e100, 1.0, 1e100, 1e100)
    with pytest.raises(ValueError, match="overflow"):
        f.filter([1.0, 2.0, 3.0, 4.0, 5.0], [0.0, 1e150, 2e150, 3e150, 4e150])
    g = KalmanFilterCV(1.0, 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="overflow"):  # a slope beyond float64
        g.filter([-1e150, 1e150, 0.0, 1.0], [0.0, 1e-300, 1.0, 2.0])


@pytest.mark.parametrize("cls", CLASSES)
def test_bad_streaming(cls):
    f = cls(1.0, 1.0, 1.0)
    f.step(1.0, 0.0)
    with pytest.raises(ValueError, match="increase"):
        f.step(1.0, 0.0)
    with pytest.raises(ValueError, match="increase"):
        f.step(1.0, -3.0)
    with pytest.raises(ValueError, match="series"):
        f.step([1.0, 2.0], 5.0)
    with pytest.raises(ValueError, match="within"):
        f.step(np.inf, 5.0)
    with pytest.raises(TypeError):
        f.step("x", 5.0)
    with pytest.raises(ValueError, match="finite"):
        f.step(1.0, np.nan)
    g = cls(1.0, 1.0, 1.0)
    with pytest.raises(ValueError):
        g.step([], 0.0)
    with pytest.raises(ValueError):
        g.step(np.ones((2, 2)), 0.0)


def test_bad_streaming_leaves_the_state_unchanged():
    f = FuzzyFilter(1.0, 1.0, 1.0, 1.0, 1.0)
    ref = FuzzyFilter(1.0, 1.0, 1.0, 1.0, 1.0)
    for t, z in enumerate([1.0, 2.0, 2.5]):
        f.step([z, z], t)
        ref.step([z, z], t)
    for bad in ([np.inf, 1.0], [1.0, 1e300]):
        with pytest.raises(ValueError):
            f.step(bad, 3.0)
    np.testing.assert_array_equal(f.step([4.0, 4.0], 3.0), ref.step([4.0, 4.0], 3.0))


def test_bad_detector_settings():
    f = FuzzyFilter(1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="method"):
        ChangeDetector(f, "bayes")
    with pytest.raises(TypeError, match="FuzzyFilter"):
        ChangeDetector("fuzzy")  # type: ignore[arg-type]
    for c in (0.0, 1.0, -0.5, np.nan):
        with pytest.raises(ValueError, match="confidence"):
            ChangeDetector(f, confidence=c)
    with pytest.raises(ValueError, match="window"):
        ChangeDetector(f, "chi2", window=0)
    with pytest.raises(ValueError, match="window"):
        ChangeDetector(f, "chi2", window=5000)
    with pytest.raises(TypeError, match="window"):
        ChangeDetector(f, "chi2", window=2.5)
    with pytest.raises(ValueError, match="drift"):
        ChangeDetector(f, "cusum", drift=0.0)
    with pytest.raises(ValueError, match="drift"):
        ChangeDetector(f, "cusum", drift=50.0)
    with pytest.raises(ValueError, match="too close to 1"):
        ChangeDetector(f, "cusum", confidence=1 - 1e-9)  # run length beyond the accurate range
    with pytest.raises(ValueError, match="beyond 40"):
        ChangeDetector(f, "cusum", confidence=1 - 1e-7, drift=0.02)


def test_bad_effective_memory():
    with pytest.raises(ValueError, match="gains"):
        effective_memory([[1.0, 0.1, 0.2]])
    with pytest.raises(ValueError, match="gains"):
        effective_memory([1.5, 0.0])
    with pytest.raises(ValueError, match="level"):
        effective_memory([0.5, 0.1], level=0.0)
    with pytest.raises(ValueError, match="gains"):
        effective_memory(KalmanFilterCV(1, 1, 1, 1, 1, R_vel=1.0).gains(3))
    with pytest.raises(ValueError, match="decay"):
        effective_memory([1.0, 3.0])  # an unstable steady filter


def test_corrupted_pickles_are_errors():
    f = FuzzyFilter(1.0, 1.0, 1.0)
    f.step(1.0)
    state = f.__getstate__()
    values, scalar, t_last = state["stream"]
    state["stream"] = (values[:-1], scalar, t_last)
    g = FuzzyFilter(1.0, 1.0, 1.0)
    with pytest.raises(ValueError, match="saved state"):
        g.__setstate__(state)
    values = values.copy()
    values[1] = 0.5  # the "started" flag
    state["stream"] = (values, scalar, t_last)
    with pytest.raises(ValueError, match="saved state"):
        g.__setstate__(state)
    d = ChangeDetector(f, "chi2", window=4)
    d.step(1.0)
    blob = d.__getstate__()
    blob["settings"] = dict(blob["settings"], window=5)
    with pytest.raises(ValueError, match="saved state"):
        pickle.loads(pickle.dumps(d)).__setstate__(blob)


def test_plot_arguments_are_checked():
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kalmanfield.trajectory import plot_change_points, plot_gain_comparison

    z = np.r_[np.zeros(30), np.full(30, 10.0)]
    batch = np.stack([z, -z])
    found = ChangeDetector(FuzzyFilter(1.0, 0.1, 0.2)).run(batch)
    fig, ax = plt.subplots()
    try:
        with pytest.raises(TypeError, match="found"):
            plot_change_points(batch, FuzzyFilter(1.0, 0.1, 0.2).filter(batch), ax=ax)
        with pytest.raises(ValueError, match="shape"):
            plot_change_points(z, found, ax=ax)
        with pytest.raises(ValueError, match="below 2"):
            plot_change_points(batch, found, series=2, ax=ax)
        with pytest.raises(ValueError, match="non-negative"):
            plot_change_points(batch, found, series=-1, ax=ax)
        with pytest.raises(TypeError, match="real numbers"):
            plot_change_points(batch, found, times=np.arange(60).astype(str), ax=ax)
        with pytest.raises(ValueError, match="times"):
            plot_change_points(batch, found, times=np.arange(59.0), ax=ax)
        with pytest.raises(ValueError, match="figure"):
            plot_gain_comparison(True)
        # the valid calls draw the chosen series at the given times (per series too)
        t = np.stack([np.arange(60.0), 2 * np.arange(60.0)])
        plot_change_points(batch, found, times=t, series=1, ax=ax)
        x, y = ax.lines[0].get_data()
        np.testing.assert_array_equal(x, t[1])
        np.testing.assert_array_equal(y, -z)
    finally:
        plt.close("all")
