"""Rust identification kernels == their NumPy twins (method page *Identification*, §1.6), and the
FFT sample correlation == direct sums, on data with missing values."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import kalmanfield as kf
from kalmanfield import _core
from kalmanfield.reference.identification import kernels as ref


@st.composite
def arrays_with_gaps(draw, max_dims=3):
    shape = draw(hnp.array_shapes(min_dims=1, max_dims=max_dims, min_side=2, max_side=40))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(shape).cumsum(axis=-1)  # correlated, like images
    x[rng.random(shape) < draw(st.sampled_from([0.0, 0.05, 0.3]))] = np.nan
    return x


def _close(a, b, scale):
    np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-11 * max(scale, 1.0))


@given(arrays_with_gaps(), st.integers(0, 2), st.integers(1, 8))
def test_difference_gram_matches_reference(x, axis, order):
    axis %= x.ndim
    gram, count = _core.difference_gram(x, axis, order)
    want, want_count = ref.difference_gram(x, axis, order)
    assert count == want_count
    _close(gram, want, np.abs(want).max(initial=0))
    np.testing.assert_array_equal(gram, gram.T)


@given(arrays_with_gaps(), st.integers(0, 2), st.integers(0, 45))
def test_lag_products_match_reference(x, axis, max_lag):
    axis %= x.ndim
    sums, counts = _core.lag_products(x, axis, max_lag)
    want, want_counts = ref.lag_products(x, axis, max_lag)
    np.testing.assert_array_equal(counts, want_counts)
    _close(sums, want, np.nansum(x**2))


@given(arrays_with_gaps(), st.integers(0, 2), st.floats(-0.99, 0.99), st.integers(0, 5))
def test_whitening_matches_reference(x, axis, rho, order):
    axis %= x.ndim
    got = x.copy()
    _core.whiten_axis_into(got, axis, rho, order)
    want = ref.whiten_axis(x, axis, rho, order)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    _close(got[~np.isnan(got)], want[~np.isnan(want)], np.nanmax(np.abs(x), initial=1.0))


def test_kernels_are_thread_count_independent():
    x = kf.ARFieldModel([0.9, 0.8], [2, 1]).sample((300, 257), seed=3)
    for axis in (0, 1):
        one = _core.difference_gram(x, axis, 4, 1)[0]
        two = _core.difference_gram(x, axis, 4, 2)[0]
        np.testing.assert_array_equal(one, two)
        np.testing.assert_array_equal(
            _core.lag_products(x, axis, 7, 1)[0], _core.lag_products(x, axis, 7, 2)[0]
        )


@given(arrays_with_gaps(max_dims=3), st.booleans(), st.data())
def test_fft_sample_correlation_matches_direct_sums(x, unbiased, data):
    if not np.isfinite(x).sum() >= 2 or np.nanstd(x) == 0:
        return
    lags = tuple(data.draw(st.integers(0, n - 1)) for n in x.shape)
    estimator = "unbiased" if unbiased else "biased"
    got = kf.sample_correlation(x, lags, estimator=estimator)
    want = ref.sample_correlation(x, lags, unbiased)
    assert got.shape == tuple(2 * lag + 1 for lag in lags)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got[~np.isnan(got)], want[~np.isnan(want)], atol=1e-9)


def test_sample_correlation_is_scale_free():
    # computed in units of the data's peak: values of 1e200 (squares overflow) or 1e-200
    # (squares underflow) give the correlation of the same data at unit scale
    x = kf.ARFieldModel([0.9, 0.8], [2, 1]).sample((40, 30), seed=2)
    want = kf.sample_correlation(x, (3, 4))
    for scale in (1e-200, 1e200):
        np.testing.assert_allclose(kf.sample_correlation(x * scale, (3, 4)), want, atol=1e-12)


def test_mask_masked_array_and_nan_agree():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((30, 40)).cumsum(axis=1)
    hide = rng.random(x.shape) < 0.2
    with_nan = np.where(hide, np.nan, x)
    a = kf.sample_correlation(x, (3, 5), mask=hide)
    b = kf.sample_correlation(np.ma.MaskedArray(x, mask=hide), (3, 5))
    c = kf.sample_correlation(with_nan, (3, 5))
    np.testing.assert_allclose(a, b, atol=1e-12)
    np.testing.assert_allclose(a, c, atol=1e-12)


def bartlett_se(correlation, lag, n_points, reach=60):
    """Bartlett's large-sample SE of a sample correlation at `lag` of a Gaussian field:
    var r_h ≈ (1/N) Σ_k [ρ_k² + ρ_{k+h} ρ_{k−h} − 4 ρ_h ρ_k ρ_{k+h} + 2 ρ_h² ρ_k²], k ∈ Z²."""
    k1, k2 = np.meshgrid(*2 * [np.arange(-reach, reach + 1)], indexing="ij")
    rk, rh = correlation(k1, k2), correlation(*lag)
    plus = correlation(k1 + lag[0], k2 + lag[1])
    minus = correlation(k1 - lag[0], k2 - lag[1])
    terms = rk**2 + plus * minus - 4 * rh * rk * plus + 2 * rh**2 * rk**2
    return np.sqrt(terms.sum() / n_points)


def test_sample_correlation_of_an_ar1_field_within_standard_error():
    # AR(1) along both axes: R(h₁, h₂) = ρ^(|h₁| + |h₂|)
    rho, n = 0.6, 512
    x = kf.ARFieldModel(rho, [1, 1]).sample((n, n), seed=11)
    r = kf.sample_correlation(x, 1)

    def correlation(a, b):
        return rho ** (np.abs(a) + np.abs(b))

    for lag in ((1, 0), (0, 1), (1, 1), (1, -1)):
        se = bartlett_se(correlation, lag, n * n)  # 0.0023 at (1, 0), 0.0033 at (1, 1)
        assert abs(r[1 + lag[0], 1 + lag[1]] - correlation(*lag)) < 5 * se
    np.testing.assert_allclose(r, r[::-1, ::-1], atol=1e-12)  # R(-h) = R(h)


def test_integer_images_are_accepted():
    rng = np.random.default_rng(2)
    img = rng.integers(0, 256, size=(20, 30)).astype(np.uint8)
    np.testing.assert_allclose(
        kf.sample_correlation(img, 2), kf.sample_correlation(img.astype(float), 2)
    )
    np.testing.assert_allclose(
        kf.sample_correlation(img.astype(np.uint16) * 200, 2), kf.sample_correlation(img, 2)
    )


def test_chi2_helpers():
    scipy_stats = pytest.importorskip("scipy.stats")
    for x, dof in [(3.0, 1), (12.5, 10), (0.0, 4), (80.0, 50)]:
        assert _core.chi2_sf(x, dof) == pytest.approx(scipy_stats.chi2.sf(x, dof), rel=1e-9)
    assert _core.chi2_quantile(0.99, 4) == pytest.approx(scipy_stats.chi2.ppf(0.99, 4), rel=1e-9)


@pytest.mark.parametrize("estimator", ["biased", "unbiased"])
def test_lags_without_valid_pairs_are_nan(estimator):
    """Found by hypothesis in CI: the biased estimator gave a value at a lag with no pair."""
    x = np.full((40, 3), np.nan)
    x[1, 0], x[30, 2], x[5, 1] = 1.0, 2.0, 0.5
    got = kf.sample_correlation(x, (36, 0), estimator=estimator)
    want = ref.sample_correlation(x, (36, 0), estimator == "unbiased")
    np.testing.assert_array_equal(np.isnan(got), np.isnan(want))
    np.testing.assert_allclose(got[~np.isnan(got)], want[~np.isnan(want)], atol=1e-12)
    assert np.isnan(got[0, 0])  # lag -36: no pair of valid pixels
