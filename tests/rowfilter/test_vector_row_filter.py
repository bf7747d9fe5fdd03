"""The optimal vector row filter and the Wiener bound (method page *Row filters*, §2.1–2.2,
§2.4)."""

import pickle

import numpy as np
import pytest
from filter_support import exact_mse, noisy
from hypothesis import given
from hypothesis import strategies as st

import kalmanfield as kf
from kalmanfield.reference.rowfilter import row_filters as ref


@given(
    st.integers(1, 4),
    st.integers(1, 4),
    st.floats(0.3, 0.97),
    st.floats(0.3, 0.97),
    st.integers(1, 12),
    st.integers(1, 10),
    st.floats(0.05, 10.0),
    st.booleans(),
)
def test_rust_equals_reference(n_y, n_x, rho_y, rho_x, height, width, noise_var, smooth):
    model = kf.ARFieldModel([rho_y, rho_x], [n_y, n_x], sigma=1.3)
    _, z = noisy(model, (height, width), noise_var, 3)
    f = kf.VectorRowFilter(model, noise_var, width, smooth)
    want, want_var = ref.vector_row_filter(z, model.rho, model.order, 1.3, noise_var, smooth)
    scale = np.abs(z).max()
    np.testing.assert_allclose(f.filter(z), want, atol=1e-9 * scale)
    np.testing.assert_allclose(f.error_variance(height), want_var, atol=1e-10)


@pytest.mark.parametrize("order", [(1, 1), (2, 1), (3, 2)])
@pytest.mark.parametrize("smooth", [False, True])
def test_equals_brute_force_gls(order, smooth):
    # the whole 8×6 image as one Gaussian vector: causal row t conditions on rows 1..t
    model = kf.ARFieldModel([0.85, 0.7], order, sigma=1.0)
    _, z = noisy(model, (8, 6), 0.5, 7)
    f = kf.VectorRowFilter(model, 0.5, 6, smooth)
    want, want_var = ref.brute_force_kalman(z, model.rho, model.order, 1.0, 0.5, smooth)
    np.testing.assert_allclose(f.filter(z), want, atol=1e-10)
    np.testing.assert_allclose(f.error_variance(8), want_var, atol=1e-10)


def test_smoother_stays_the_posterior_mean_for_slowly_decaying_rows():
    # n_y = 4, ρ = 0.99, σ_θ² = 1e-4: P_e of the high-variance modes has a condition of ~1e12.
    # The Riccati update P_e − k (P_e)_h· let P drift from symmetric and P_e round to
    # indefinite; the smoother gain then vanished (errors up to 0.47 σ_θ, map 2.4× the bound).
    model, noise_var, shape = kf.ARFieldModel([0.99, 0.99], [4, 1]), 1e-4, (40, 24)
    _, z = noisy(model, shape, noise_var, 1)
    want, _ = ref.brute_force_kalman(z, model.rho, model.order, 1.0, noise_var, smooth=True)
    twin, _ = ref.vector_row_filter(z, model.rho, model.order, 1.0, noise_var, smooth=True)
    f = kf.VectorRowFilter(model, noise_var, shape[1], smooth=True)
    np.testing.assert_allclose(f.filter(z), want, atol=1e-3 * np.sqrt(noise_var))
    np.testing.assert_allclose(twin, want, atol=1e-3 * np.sqrt(noise_var))
    bound = kf.wiener_error_map(model, noise_var, shape)
    np.testing.assert_allclose(f.error_variance(shape[0]), bound, rtol=1e-3)


@pytest.mark.parametrize(("order", "noise_var"), [((4, 1), 1.0), ((4, 2), 1e-4)])
def test_smoother_attains_the_bound_where_four_rows_correlate_to_rounding(order, noise_var):
    # n_y = 4 at ρ = 0.999: R_y[:4,:4] has a condition ~3e17. With the per-mode Riccati in the
    # rows' own basis P_e rounded indefinite, those modes' smoother gain fell to 0 and the
    # smoothed image lay 1.18× ((4,1)) and 1.09× ((4,2)) above the bound; in the whitened
    # basis of the rows it is at the bound (exact MSE, 32²)
    model, shape = kf.ARFieldModel([0.999, 0.999], order), (32, 32)
    f = kf.VectorRowFilter(model, noise_var, shape[1], smooth=True)
    bound = kf.wiener_bound(model, noise_var, shape)
    assert exact_mse(f, model, noise_var, shape) == pytest.approx(bound, rel=5e-3)


@pytest.mark.parametrize("order", [(1, 2), (2, 2), (3, 3), (4, 1)])
def test_a_tall_causal_map_equals_the_reference_row_by_row(order):
    # the kernel copies the rows after its Riccati step reaches a fixed point; the twin
    # iterates every row (in the rows' basis: for (4,1) its rounding reaches ~1e-10 here)
    model, shape = kf.ARFieldModel([0.9, 0.8], order, sigma=1.3), (600, 6)
    want = ref.vector_error_map(model.rho, model.order, 1.3, 0.2, shape)
    np.testing.assert_allclose(
        kf.VectorRowFilter(model, 0.2, 6).error_variance(600), want, rtol=1e-9
    )


@pytest.mark.parametrize("order", [(2, 2), (4, 4)])
def test_the_causal_map_keeps_its_digits_at_extreme_snr(order):
    # σ_θ² = 1e-30 σ_x²: the error variance is σ_θ² (1 − O(σ_θ²)); read off P − c cᵀ/s it
    # was ~1e12 σ_θ² on row 0 and 0 after it (cancellation)
    f = kf.VectorRowFilter(kf.ARFieldModel([0.9, 0.9], order), 1e-30, 12)
    np.testing.assert_allclose(f.error_variance(40) / 1e-30, 1.0, rtol=1e-9)


@pytest.mark.parametrize("order", [(2, 2), (3, 3), (4, 4), (4, 1)])
@pytest.mark.parametrize("noise_var", [1e-8, 1e-16, 1e-30])
def test_the_smoothed_map_keeps_its_digits_at_extreme_snr(order, noise_var):
    # the smoother is the posterior mean, so its map is the Wiener map (eigenbases of both
    # axes, nothing cancelling); by the RTS covariances it was off by 1e-8 relative at
    # σ_θ² = 1e-8 σ_x², 10 % at 1e-16 and ×1e12 at 1e-30 — now the modes with σ_θ²/v_j ≤ 1e-4
    # take it from the information form (rust/src/column_precision.rs)
    model = kf.ARFieldModel([0.9, 0.9], order)
    f = kf.VectorRowFilter(model, noise_var, 12, smooth=True)
    got = f.error_variance(40)
    np.testing.assert_allclose(got, kf.wiener_error_map(model, noise_var, (40, 12)), rtol=1e-7)
    twin = ref.vector_error_map(model.rho, model.order, 1.0, noise_var, (40, 12), smooth=True)
    # the weak modes (σ_θ²/v_j > 1e-4 at σ_θ² = 1e-8) keep the RTS form, ~1e-8 on either side
    np.testing.assert_allclose(got, twin, rtol=1e-7)


@pytest.mark.parametrize("order", [(1, 2), (2, 2), (4, 3)])
def test_the_smoothed_map_of_both_forms_equals_the_reference(order):
    # σ = 10, σ_θ² = 0.01: the strongest modes (σ_θ²/v_j ~ 1e-5) take the information form,
    # the weak ones the RTS covariances
    model = kf.ARFieldModel([0.8, 0.9], order, sigma=10.0)
    f = kf.VectorRowFilter(model, 0.01, 24, smooth=True)
    ratios = 0.01 / (100 * np.linalg.eigvalsh(ref.axis_covariance(0.9, order[1], 24)))
    assert ratios.min() <= ref.INFORMATION_RATIO < ratios.max()
    twin = ref.vector_error_map(model.rho, model.order, 10.0, 0.01, (30, 24), smooth=True)
    np.testing.assert_allclose(f.error_variance(30), twin, rtol=1e-9)
    np.testing.assert_allclose(twin, kf.wiener_error_map(model, 0.01, (30, 24)), rtol=1e-9)


def test_error_variance_matches_monte_carlo():
    # per-pixel MSE over R realisations has standard error ≈ var·√(2/R) (Gaussian errors)
    model = kf.ARFieldModel([0.9, 0.8], [2, 1])
    shape, noise_var, reps = (10, 8), 1.0, 3000
    x = np.stack([model.sample(shape, seed=s) for s in range(reps)])
    z = x + np.random.default_rng(1).standard_normal(x.shape)
    for smooth in (False, True):
        f = kf.VectorRowFilter(model, noise_var, shape[1], smooth)
        mse = ((f.filter(z) - x) ** 2).mean(axis=0)
        var = f.error_variance(shape[0])
        se = var * np.sqrt(2 / reps)
        assert np.all(np.abs(mse - var) < 5 * se)
        if not smooth:
            assert var[0].mean() > var[-1].mean()  # the first row knows least
        else:  # the smoother sees the image from both sides
            np.testing.assert_allclose(var, var[::-1, ::-1], atol=1e-12)


def test_smoother_attains_the_wiener_bound():
    model = kf.ARFieldModel([0.9, 0.95], [2, 3], sigma=2.0)
    f = kf.VectorRowFilter(model, 0.3, 20, smooth=True)
    np.testing.assert_allclose(f.error_variance(15), kf.wiener_error_map(model, 0.3, (15, 20)))
    assert kf.wiener_bound(model, 0.3, (15, 20)) == pytest.approx(
        ref.wiener_bound(model.rho, model.order, 2.0, 0.3, (15, 20)), rel=1e-12
    )
    causal = kf.VectorRowFilter(model, 0.3, 20).error_variance(15).mean()
    assert causal > kf.wiener_bound(model, 0.3, (15, 20))


def test_wiener_bound_limits():
    model = kf.ARFieldModel([0.8, 0.8], [1, 1], sigma=1.0)
    # tiny noise: the error is about the noise; huge noise: about the field variance
    assert kf.wiener_bound(model, 1e-6, (6, 6)) == pytest.approx(1e-6, rel=1e-3)
    assert kf.wiener_bound(model, 1e6, (6, 6)) == pytest.approx(1.0, rel=1e-3)


def test_stack_dtypes_mean_and_pickle():
    model = kf.ARFieldModel([0.9, 0.9], [1, 2], sigma=10.0)
    stack = np.stack([noisy(model, (16, 12), 4.0, s)[1] + 100 for s in range(3)])
    f = kf.VectorRowFilter(model, 4.0, 12, mean=100.0, threads=2)
    assert (f.model, f.noise_var, f.width, f.smooth) == (model, 4.0, 12, False)
    out = f.filter(stack)
    # the filter acts on the deviation from the mean, causal and smoothed alike
    for smooth in (False, True):
        centred = kf.VectorRowFilter(model, 4.0, 12, smooth=smooth).filter(stack - 100.0)
        with_mean = kf.VectorRowFilter(model, 4.0, 12, smooth=smooth, mean=100.0)
        np.testing.assert_allclose(with_mean.filter(stack), centred + 100.0, rtol=0, atol=1e-11)
    for k in range(3):
        np.testing.assert_allclose(out[k], f.filter(stack[k]), atol=1e-12)
    np.testing.assert_allclose(
        f.filter(stack.astype(np.float32)), f.filter(stack.astype(np.float32).astype(float))
    )
    img8 = np.clip(stack[0], 0, 255).astype(np.uint8)
    np.testing.assert_allclose(f.filter(img8), f.filter(img8.astype(float)))
    again = pickle.loads(pickle.dumps(f))
    np.testing.assert_array_equal(again.filter(stack), out)
    assert "VectorRowFilter" in repr(again)


@pytest.mark.parametrize(
    "make,exc,match",
    [
        (lambda m: kf.VectorRowFilter(m, 0.0, 8), ValueError, "noise_var"),
        (lambda m: kf.VectorRowFilter(m, float("nan"), 8), ValueError, "noise_var"),
        (lambda m: kf.VectorRowFilter(m, 1.0, 0), ValueError, "width"),
        (
            lambda m: kf.VectorRowFilter(kf.ARFieldModel(0.5, [1, 1, 1]), 1.0, 8),
            ValueError,
            "2-axis",
        ),
        (lambda m: kf.VectorRowFilter(kf.ARFieldModel(0.5, [5, 1]), 1.0, 8), ValueError, "up to 4"),
        (lambda m: kf.VectorRowFilter("model", 1.0, 8), TypeError, "ARFieldModel"),
        (lambda m: _filter8(m).filter(np.ones((4, 9))), ValueError, "width 8"),
        (lambda m: _filter8(m).filter(np.ones(8)), ValueError, "image"),
        (
            lambda m: _filter8(m).filter(np.full((4, 8), np.nan)),
            ValueError,
            "NaN",
        ),
        (
            lambda m: _filter8(m).filter(np.full((4, 8), np.inf)),
            ValueError,
            "infinite",
        ),
        (lambda m: _filter8(m).filter(np.ones((4, 8), bool)), TypeError, "real"),
        (lambda m: _filter8(m).error_variance(0), ValueError, "height"),
        # (the kernel kept every mode's 4 × 4 Riccati history: 25.6 GB, an abort)
        (lambda m: _filter8(m).error_variance(10**11), MemoryError, "GiB"),
        (lambda m: kf.wiener_bound(m, -1.0, (4, 4)), ValueError, "noise_var"),
        (lambda m: kf.wiener_bound(m, 1.0, (4, 4, 4)), ValueError, "axes"),
    ],
)
def test_bad_input(make, exc, match):
    with pytest.raises(exc, match=match):
        make(kf.ARFieldModel([0.9, 0.8], [1, 2]))


def _filter8(m):
    return kf.VectorRowFilter(m, 1.0, 8)
