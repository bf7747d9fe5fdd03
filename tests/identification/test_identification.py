"""identify and yule_walker (method page *Identification*, §1.6): exact recovery from exact
covariances, statistical recovery from simulated fields, real images, invariances and bad
input."""

import pickle

import numpy as np
import pytest
from scipy.stats import chi2

import kalmanfield as kf
from kalmanfield.identification.yule_walker import yule_walker_from_covariance
from kalmanfield.reference.identification import kernels as ref_id

_RNG = np.random.default_rng(12)


@pytest.mark.parametrize(
    "rho,order", [((0.9, 0.7), (1, 1)), ((0.8, 0.6), (2, 2)), ((0.5, 0.9), (1, 3))]
)
def test_yule_walker_on_the_exact_covariance_returns_the_template(rho, order):
    model = kf.ARFieldModel(rho, order, sigma=1.5)
    lags = np.stack(
        np.meshgrid(
            np.arange(-order[0], order[0] + 1), np.arange(-order[1], order[1] + 1), indexing="ij"
        ),
        axis=-1,
    )
    fit = yule_walker_from_covariance(model.correlation(lags))
    np.testing.assert_allclose(fit.alpha, model.coefficients(), atol=1e-8)
    assert fit.beta == pytest.approx(model.beta, rel=1e-8)
    assert fit.variance == pytest.approx(2.25)


def test_yule_walker_on_a_simulated_field():
    model = kf.ARFieldModel([0.8, 0.6], [1, 1], sigma=2.0)
    x = model.sample((512, 512), seed=5) + 3.0
    fit = kf.yule_walker(x, (1, 1))
    np.testing.assert_allclose(fit.alpha, model.coefficients(), atol=0.01)
    assert fit.beta == pytest.approx(model.beta, rel=0.02)
    assert fit.mean == pytest.approx(3.0, abs=0.1)
    pred = fit.predict(x)
    assert np.isnan(pred[0]).all() and np.isnan(pred[:, 0]).all()
    residual = (x - pred)[1:, 1:]
    assert residual.std() == pytest.approx(model.beta, rel=0.02)
    # a mask leaves its pixels out exactly as NaN does
    holes = np.random.default_rng(1).random(x.shape) < 0.1
    masked = kf.yule_walker(x, (1, 1), mask=holes)
    gappy = kf.yule_walker(np.where(holes, np.nan, x), (1, 1))
    np.testing.assert_allclose(masked.alpha, gappy.alpha, rtol=1e-12)
    assert masked.beta == pytest.approx(gappy.beta, rel=1e-12) and masked.beta != fit.beta


@pytest.mark.parametrize("n", [1, 2, 3, 4])
@pytest.mark.parametrize("rho", [0.8, 0.95])
def test_identify_recovers_multiplicity_and_rho(n, rho):
    # The benchmark (benches/bench_identify.py) measures a ρ RMSE below 1 % on 256² fields;
    # 0.02 is several RMSEs on the 192² fields used here.
    model = kf.ARFieldModel([rho, rho], [n, n], sigma=1.0)
    x = model.sample((192, 192), seed=100 * n + int(rho * 100))
    fit = kf.identify(x)
    assert fit.order == (n, n)
    np.testing.assert_allclose(fit.rho, rho, atol=0.02)
    if rho == 0.8:  # σ² is imprecise for ρ → 1 (few independent samples), see the benchmark
        assert fit.variance == pytest.approx(1.0, rel=0.2)
    for axis, axis_fit in enumerate(fit.fits):
        assert axis_fit.criterion.argmin() == n - 1
        assert axis_fit.candidate_rho.shape == (4,)
        assert axis_fit.candidate_rho[n - 1] == fit.rho[axis]  # the winner is a candidate
        np.testing.assert_array_equal(axis_fit.candidate_orders, [1, 2, 3, 4])
        np.testing.assert_array_equal(axis_fit.lags, np.arange(axis_fit.sample_correlation.size))
        np.testing.assert_allclose(
            axis_fit.fitted_correlation[:4], axis_fit.sample_correlation[:4], atol=0.05
        )


def test_mixed_orders_stack_with_time_first():
    model = kf.ARFieldModel([0.7, 0.9, 0.6], [1, 2, 3])
    x = model.sample((64, 96, 96), seed=9)
    fit = kf.identify(x)
    assert fit.order == (1, 2, 3)
    # few independent lines along time (strong spatial correlation): SE(ρ_t) ≈ 0.02
    np.testing.assert_allclose(fit.rho, model.rho, atol=0.05)


def test_variance_estimate_is_unbiased():
    # σ̂² corrects the sample variance for the mean's uncertainty: over 30 fields with
    # ρ = 0.95 (correlation length ~ a tenth of the grid) its mean is within 3 SE of σ² = 2.
    model = kf.ARFieldModel(0.95, [1, 1], sigma=np.sqrt(2))
    fits = [kf.identify(model.sample((128, 128), seed=s), max_order=2) for s in range(30)]
    est = np.array([f.variance for f in fits])
    raw = np.array([f.sample_variance for f in fits])
    se = est.std(ddof=1) / np.sqrt(est.size)
    assert abs(est.mean() - 2.0) < 3 * se
    assert raw.mean() < est.mean()


def test_replicate_axes_are_pooled():
    model = kf.ARFieldModel([0.9, 0.8], [2, 1])
    stack = np.stack([model.sample((128, 128), seed=s) for s in range(3)], axis=-1)
    fit = kf.identify(stack, axes=(0, 1))
    assert fit.axes == (0, 1) and fit.order == (2, 1)
    np.testing.assert_allclose(fit.rho, model.rho, atol=0.02)


@pytest.mark.filterwarnings("ignore:rho along axis:RuntimeWarning")
def test_true_model_residual_passes_the_whiteness_test():
    model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    fit = kf.identify(model.sample((256, 256), seed=21))
    # the residual recomputed here: the field less its mean, whitened along both axes by
    # (1 − ρ z⁻¹)ⁿ of the fitted orders and the test's ρ (the twin; NaN where a line has no
    # n predecessors); the test's ρ is the fitted one within the fit's error
    tested = fit.fits[0].whiteness.whitened_with
    np.testing.assert_allclose(tested, fit.rho, atol=0.01)
    residual = model.sample((256, 256), seed=21) - fit.mean
    for axis in (0, 1):
        residual = ref_id.whiten_axis(residual, axis, tested[axis], fit.order[axis])
    for axis, axis_fit in enumerate(fit.fits):
        w = axis_fit.whiteness
        assert w.dof == 10 and w.residual_correlation.shape == (10,)
        assert w.pvalue > 1e-3
        sums, counts = ref_id.lag_products(residual, axis, 10)
        r = (sums[1:] / counts[1:]) / (sums[0] / counts[0])
        np.testing.assert_allclose(w.residual_correlation, r, rtol=1e-9, atol=1e-12)
        box_pierce = float(np.sum(counts[1:] * r**2))
        assert w.statistic == pytest.approx(box_pierce, rel=1e-9)
        assert w.pvalue == pytest.approx(chi2.sf(box_pierce, 10), rel=1e-9)
    # a wrong order leaves correlated residuals: the test must reject it
    wrong = kf.ARFieldModel([0.9, 0.9], [1, 1]).sample((256, 256), seed=22)
    smooth = kf.identify(np.cumsum(wrong, axis=1) / 10, max_order=1)
    assert smooth.fits[1].whiteness.pvalue < 1e-6


def test_affine_invariance_missing_pixels_and_dtypes():
    model = kf.ARFieldModel([0.9, 0.8], [2, 2], sigma=1.0)
    x = model.sample((200, 200), seed=4)
    base = kf.identify(x)
    scaled = kf.identify(7.0 * x + 100.0)
    assert scaled.order == base.order
    np.testing.assert_allclose(scaled.rho, base.rho, rtol=1e-6)  # flat optimum: ~√ε
    assert scaled.variance == pytest.approx(49 * base.variance, rel=1e-4)
    assert scaled.mean == pytest.approx(100 + 7 * base.mean, rel=1e-9)
    holes = np.random.default_rng(0).random(x.shape) < 0.1
    gappy = kf.identify(np.where(holes, np.nan, x))
    assert gappy.order == base.order
    np.testing.assert_allclose(gappy.rho, base.rho, atol=0.02)
    masked = kf.identify(x, mask=holes)
    np.testing.assert_allclose(masked.rho, gappy.rho, rtol=1e-12)
    assert masked.variance == gappy.variance
    image = np.clip(40 * x + 128, 0, 255).astype(np.uint8)
    assert kf.identify(image).order == base.order
    assert kf.identify(image.astype(np.uint16)).rho == kf.identify(image).rho


def test_result_is_usable_and_picklable():
    fit = kf.identify(kf.ARFieldModel(0.85, [1, 2]).sample((128, 128), seed=1))
    assert isinstance(fit.model, kf.ARFieldModel)
    assert fit.model.rho == fit.rho and fit.model.order == fit.order
    assert fit.model.sigma**2 == pytest.approx(fit.variance, rel=1e-12)
    assert "axis 0" in fit.summary() and "axis 1" in fit.summary()
    again = pickle.loads(pickle.dumps(fit))
    assert again.model == fit.model
    assert fit.model.sample((8, 8), seed=1).shape == (8, 8)


def test_plot():
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    fit = kf.identify(kf.ARFieldModel(0.85, [1, 2]).sample((64, 64), seed=1))
    assert len(fit.plot()) == 2


@pytest.mark.parametrize("name", ["camera", "brick", "grass", "gravel", "astronaut", "coins"])
def test_real_images(name):
    data = pytest.importorskip("skimage.data")
    image = getattr(data, name)()
    fit = kf.identify(image, axes=(0, 1))
    assert all(1 <= n <= 4 for n in fit.order)
    assert all(0.2 < r < 1 for r in fit.rho)
    assert fit.mean == pytest.approx(image.mean(), rel=1e-9)
    # the model reproduces the short-range correlation it was fitted to
    for axis_fit in fit.fits:
        np.testing.assert_allclose(
            axis_fit.fitted_correlation[1:3], axis_fit.sample_correlation[1:3], atol=0.07
        )
    assert 0.5 < fit.variance / fit.sample_variance < 2


@pytest.mark.parametrize(
    "data,kwargs,exc,match",
    [
        (np.full((50, 50), 3.0), {}, ValueError, "constant"),
        (np.full((50, 50), np.nan), {}, ValueError, "no valid"),
        (np.zeros((5, 5)) + np.arange(5), {}, ValueError, "too few|constant"),
        (np.random.default_rng(0).random((4, 40)), {}, ValueError, "too few"),
        (np.random.default_rng(0).random((40, 40)), {"max_order": 9}, ValueError, "at most"),
        (np.random.default_rng(0).random((40, 40)), {"max_order": 0}, ValueError, "positive"),
        (np.random.default_rng(0).random((4, 4, 4, 4)), {}, ValueError, "1-D, 2-D or 3-D"),
        (np.float64(3.0), {}, ValueError, "1-D, 2-D or 3-D"),
        (np.random.default_rng(0).random((40, 40)), {"axes": (0, 0)}, ValueError, "distinct"),
        (np.random.default_rng(0).random((40, 40)), {"axes": (2,)}, ValueError, "out of range"),
        (np.ones((40, 40), dtype=bool), {}, TypeError, "real numbers"),
        (np.ones((40, 40), dtype=complex), {}, TypeError, "real numbers"),
        (
            np.random.default_rng(0).random((40, 40)),
            {"mask": np.ones(3, bool)},
            ValueError,
            "shape",
        ),
    ],
)
def test_identify_bad_input(data, kwargs, exc, match):
    with pytest.raises(exc, match=match):
        kf.identify(data, **kwargs)


@pytest.mark.filterwarnings("ignore:rho along axis 0:RuntimeWarning")
def test_constant_lines_and_trends():
    rows = np.repeat(np.random.default_rng(0).random((60, 1)), 60, axis=1)
    with pytest.raises(ValueError, match="constant along axis 1"):
        kf.identify(rows)
    ramp = np.add.outer(np.arange(60.0), np.arange(60.0))
    with pytest.warns(RuntimeWarning, match="non-stationary"):
        kf.identify(ramp)


@pytest.mark.parametrize(
    "call,exc,match",
    [
        (lambda: kf.sample_correlation(np.ones((10, 10)), 2), ValueError, "constant"),
        (lambda: kf.sample_correlation(np.arange(10.0), 10), ValueError, "max_lag"),
        (lambda: kf.sample_correlation(np.arange(10.0), (1, 2)), ValueError, "one entry per axis"),
        (lambda: kf.sample_correlation(np.ones((2, 2, 2, 2)), 1), ValueError, "1-D, 2-D or 3-D"),
        (lambda: kf.sample_correlation(np.arange(10.0), 2, estimator="x"), ValueError, "estimator"),
        (lambda: kf.sample_correlation(np.full(10, np.nan), 2), ValueError, "no valid"),
        (lambda: kf.yule_walker(np.ones((5, 5, 5)), (1, 1)), ValueError, "2-D"),
        (lambda: kf.sample_correlation(np.zeros((0, 5)), 2), ValueError, "no pixels"),
        (lambda: kf.yule_walker(_RNG.random((30, 30)) * 1e300), ValueError, "overflows"),
        (lambda: kf.yule_walker(_RNG.random((3, 30)), (2, 1)), ValueError, "too small"),
        (lambda: kf.yule_walker(_RNG.random((30, 30)), (0, 0)), ValueError, "no coefficient"),
        (lambda: kf.yule_walker(_RNG.random((30, 30)), (1,)), ValueError, "pair"),
        (lambda: kf.yule_walker(_RNG.random((30, 30)), (1.5, 1)), TypeError, "integers"),
        (lambda: kf.yule_walker(_RNG.random((30, 30)), 1), TypeError, "pair"),
        (lambda: kf.sample_correlation(np.arange(10.0), 2.0), TypeError, "max_lag"),
        (lambda: kf.yule_walker(_EVERY_OTHER_COLUMN, (1, 1)), ValueError, "no pair of observed"),
        (lambda: _FIT.predict(np.ones(5)), ValueError, "2-D"),
    ],
)
def test_correlation_and_yule_walker_bad_input(call, exc, match):
    with pytest.raises(exc, match=match):
        call()


_EVERY_OTHER_COLUMN = np.where(np.arange(30) % 2, np.nan, _RNG.random((30, 30)))
_FIT = kf.yule_walker(_RNG.random((30, 30)), (1, 2))


def test_a_prediction_on_an_image_smaller_than_the_template_is_all_nan():
    assert np.isnan(_FIT.predict(np.ones((1, 5)))).all()
    assert np.isnan(_FIT.predict(np.ones((5, 2)))).all()
    assert np.isfinite(_FIT.predict(np.ones((2, 3)))[1, 2])


def test_identification_is_scale_free_and_refuses_variances_beyond_float64():
    """The fits run on the data times a power of two: the same ρ at any scale (1e-160 data
    had underflowed to a silently wrong ρ, 1e154 ones overflowed to a misleading error), σ
    and the innovation variances in data units, and a clear error where the variance itself
    leaves float64."""
    x = kf.ARFieldModel(0.9, [1, 1]).sample((64, 64), seed=1)
    base = kf.identify(x)
    for scale in (1e-140, 2.0**-400, 1e140):
        fit = kf.identify(x * scale)
        np.testing.assert_allclose(fit.model.rho, base.model.rho, rtol=1e-8)
        assert fit.model.sigma == pytest.approx(scale * base.model.sigma, rel=1e-8)
        expected = scale**2 * base.fits[0].innovation_variance
        np.testing.assert_allclose(fit.fits[0].innovation_variance, expected, rtol=1e-8)
    exact = kf.identify(x * 2.0**-400)  # a power of two: the same bits
    assert exact.model.rho == base.model.rho
    for scale in (1e-200, 1e300):
        with pytest.raises(ValueError, match="variance .* is beyond float64: rescale them"):
            kf.identify(x * scale)
    with pytest.raises(ValueError, match="underflows float64: rescale"):
        kf.yule_walker(x * 1e-170, (1, 1))
    huge = x.copy()
    huge[0, :2] = [1.7e308, -1.7e308]  # their squares overflow
    with pytest.raises(ValueError, match="rescale them"):
        kf.identify(huge)
    with pytest.raises(ValueError, match="rescale them"):
        kf.yule_walker(huge, (1, 1))
    small = kf.yule_walker(x * 1e-100, (1, 1))
    np.testing.assert_allclose(small.alpha, kf.yule_walker(x, (1, 1)).alpha, rtol=1e-10)


def test_the_whiteness_test_is_calibrated_on_true_models():
    """The residual is whitened with ρ refitted on the data whitened along the other axes:
    over 40 grids of a (1,1) ρ = 0.9 field of 128², the test rejects the true model at 5 %
    in at most 6 of 40 grids per axis (binomial mean 2, SD 1.4: 3 SD). Whitened with the
    per-axis ρ̂ (3× the efficient SD) it rejected 15 % of them at 1 %."""
    pvalues = []
    for seed in range(40):
        fit = kf.identify(kf.ARFieldModel([0.9, 0.9], [1, 1]).sample((128, 128), seed=seed))
        pvalues.append([f.whiteness.pvalue for f in fit.fits])
    assert (np.sum(np.array(pvalues) < 0.05, axis=0) <= 6).all()
