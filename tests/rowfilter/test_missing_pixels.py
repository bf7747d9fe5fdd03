"""ScalarRowFilter with per-pixel noise variances and missing (NaN) pixels, and the Toeplitz
mode set (method page *Row filters*, §2.3 generalised)."""

import pickle

import numpy as np
import pytest

import kalmanfield as kf
from kalmanfield.denoising.denoise import local_moments
from kalmanfield.reference import row_filters as ref

CASES = [((0.9, 0.8), (1, 1)), ((0.85, 0.9), (2, 2)), ((0.7, 0.95), (1, 2)), ((0.8, 0.6), (3, 1))]


def scene(model, shape, seed, missing=0.15):
    """(z, weights): an AR image plus heteroscedastic noise, `missing` of the pixels NaN."""
    rng = np.random.default_rng(seed)
    noise_var = rng.uniform(0.2, 3.0, shape)
    z = model.sample(shape, seed=seed) + np.sqrt(noise_var) * rng.standard_normal(shape)
    weights = 1.0 / noise_var
    weights[rng.random(shape) < missing] = 0.0
    return np.where(weights > 0, z, np.nan), weights


@pytest.mark.parametrize("row_models", ["propagated", "nominal", "implied"])
@pytest.mark.parametrize("modes", ["exact", "toeplitz"])
@pytest.mark.parametrize("smooth", [False, True])
@pytest.mark.parametrize("rho,order", CASES)
def test_weighted_rust_equals_reference(rho, order, smooth, modes, row_models):
    model = kf.ARFieldModel(list(rho), list(order), sigma=1.3)
    z, weights = scene(model, (13, 11), seed=sum(order))
    noise = np.where(weights > 0, 1.0 / np.where(weights > 0, weights, 1.0), np.inf)
    filt = kf.ScalarRowFilter(model, 0.7, 11, smooth=smooth, modes=modes, row_models=row_models)
    got = filt.filter(z, noise)
    plan = ref.scalar_filter_plan(rho, order, 1.3, 0.7, 11, 13, modes=modes)
    want = ref.scalar_row_filter(
        np.nan_to_num(z),
        rho,
        order,
        1.3,
        0.7,
        smooth=smooth,
        plan=plan,
        weights=weights,
        row_models=row_models,
    )
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, want, atol=1e-10, rtol=0)


@pytest.mark.parametrize("smooth", [False, True])
def test_constant_noise_map_is_the_plain_filter(smooth):
    model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    z = model.sample((20, 16), seed=3) + np.random.default_rng(3).standard_normal((20, 16))
    filt = kf.ScalarRowFilter(model, 1.0, 16, smooth=smooth)
    np.testing.assert_allclose(filt.filter(z, noise_var=1.0), filt.filter(z), atol=1e-12)
    # inf noise variance and NaN are the same missing pixel
    holes = z.copy()
    holes[4, 5] = holes[10, :3] = np.nan
    inf = np.ones_like(z)
    inf[np.isnan(holes)] = np.inf
    np.testing.assert_allclose(filt.filter(holes), filt.filter(z, noise_var=inf), atol=1e-12)


def test_stack_with_a_shared_noise_map():
    model = kf.ARFieldModel([0.8, 0.8], [1, 1])
    rng = np.random.default_rng(5)
    frames = rng.standard_normal((3, 9, 10))
    noise = rng.uniform(0.5, 2.0, (9, 10))
    filt = kf.ScalarRowFilter(model, 1.0, 10, smooth=True)
    stack = filt.filter(frames, noise_var=noise)
    for f in range(3):
        np.testing.assert_allclose(stack[f], filt.filter(frames[f], noise_var=noise), atol=1e-13)


def filter_matrix(filt, shape, holes):
    """G with x̂ = G z (z with NaN at `holes`; those columns are zero)."""
    size = shape[0] * shape[1]
    basis = np.eye(size).reshape(size, *shape)
    basis[:, holes] = np.nan
    out = filt.filter(basis).reshape(size, size).T
    out[:, holes.ravel()] = 0.0
    return out


@pytest.mark.parametrize("rho,order", [((0.9, 0.9), (1, 1)), ((0.9, 0.85), (2, 2))])
def test_missing_pixels_near_the_exact_posterior(rho, order):
    """Smoothed MSE with 20 % missing pixels vs the exact posterior (GLS) on the same grid."""
    shape, noise_var = (12, 10), 0.5
    model = kf.ARFieldModel(list(rho), list(order))
    holes = np.random.default_rng(2).random(shape) < 0.2
    cov = np.kron(
        ref.axis_covariance(rho[0], order[0], shape[0]),
        ref.axis_covariance(rho[1], order[1], shape[1]),
    )
    precision = np.where(holes.ravel(), 0.0, 1.0 / noise_var)
    exact = np.trace(np.linalg.inv(np.linalg.inv(cov) + np.diag(precision))) / cov.shape[0]
    filt = kf.ScalarRowFilter(model, noise_var, shape[1], smooth=True)
    g = filter_matrix(filt, shape, holes)
    e = g - np.eye(cov.shape[0])
    noise = np.where(holes.ravel(), 0.0, noise_var)
    mse = (np.trace(e @ cov @ e.T) + np.sum(g**2 * noise[None, :])) / cov.shape[0]
    assert exact <= mse * (1 + 1e-9)
    assert mse < 1.06 * exact, (mse, exact)
    # and far below the prior variance at the missing pixels themselves
    per_pixel = np.diag(e @ cov @ e.T + (g * noise) @ g.T).reshape(shape)
    assert per_pixel[holes].mean() < 0.5


@pytest.mark.parametrize(
    "rho,order,bound", [((0.9, 0.9), (1, 1), 1.03), ((0.95, 0.9), (2, 2), 1.05)]
)
def test_toeplitz_modes_lose_little(rho, order, bound):
    """Exact MSE of the Toeplitz-mode filter vs the exact-mode one (48×48, σ_x² = σ_θ²; a
    small grid, where the row ends weigh most: measured +1.3 % and +3.3 %)."""
    shape = (48, 48)
    model = kf.ARFieldModel(list(rho), list(order))

    def mse(modes):
        filt = kf.ScalarRowFilter(model, 1.0, shape[1], smooth=True, modes=modes)

        def estimator(zb):
            return np.moveaxis(filt.filter(np.ascontiguousarray(np.moveaxis(zb, 2, 0))), 0, 2)

        return ref.linear_estimator_mse(estimator, rho, order, 1.0, 1.0, shape).mean()

    exact, toeplitz = mse("exact"), mse("toeplitz")
    assert exact <= toeplitz < bound * exact, (exact, toeplitz)


def test_toeplitz_filter_pickles():
    filt = kf.ScalarRowFilter(kf.ARFieldModel([0.8, 0.7], [1, 2]), 0.5, 12, modes="toeplitz")
    again = pickle.loads(pickle.dumps(filt))
    assert again.modes == "toeplitz"
    z = np.random.default_rng(1).standard_normal((7, 12))
    np.testing.assert_array_equal(again.filter(z), filt.filter(z))


def test_row_models_are_checked_and_pickled():
    model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    with pytest.raises(ValueError, match="'auto', 'propagated', 'nominal' or 'implied'"):
        kf.ScalarRowFilter(model, 1.0, 8, row_models="exact")
    with pytest.raises(ValueError, match="row_models must be 'propagated', 'nominal' or 'impl"):
        kf.denoise(np.ones((8, 8)), noise_var=0.1, row_models="plan")
    for row_models in ("nominal", "implied"):
        filt = kf.ScalarRowFilter(model, 1.0, 8, smooth=True, row_models=row_models)
        assert pickle.loads(pickle.dumps(filt)).row_models == row_models
    assert kf.ScalarRowFilter(model, 1.0, 8).row_models == "propagated"


def eigen_sample(model: kf.ARFieldModel, shape: tuple[int, int], seed: int) -> np.ndarray:
    """A field of `model` through the eigendecompositions of its axes' Toeplitz correlations
    (negative rounding eigenvalues clipped): for models whose exact start float64 cannot
    resolve, which ``sample`` refuses (n_y = 4 at ρ = 0.999)."""
    factors = []
    for rho, n, size in zip(model.rho, model.order, shape):
        values, vectors = np.linalg.eigh(ref.axis_covariance(rho, n, size))
        factors.append(vectors * np.sqrt(np.clip(values, 0.0, None)))
    xi = np.random.default_rng(seed).standard_normal(shape)
    return model.sigma * factors[0] @ xi @ factors[1].T


@pytest.mark.parametrize("seed", [5, 9])
def test_a_batch_whose_lanes_do_not_factor_falls_back_to_the_propagations_factors(seed):
    # (4,4), ρ = 0.999, half the pixels missing: A_t has a condition ~1e17 and the LDLᵀ of 8
    # rows in vector lanes failed on these two seeds ("a weighted row system is not positive
    # definite") where the propagation's Cholesky of the same systems had worked; the batch
    # is now factored row by row. One image's MSE scatters 0.4–2.7× the mean of its error map
    # over seeds (errors correlated over the whole image)
    model = kf.ARFieldModel([0.999, 0.999], [4, 4])
    x = eigen_sample(model, (48, 48), seed=1)
    rng = np.random.default_rng(seed)
    z = x + rng.standard_normal(x.shape)
    z[rng.random(z.shape) < 0.5] = np.nan
    causal = kf.ScalarRowFilter(model, 1.0, 48)
    expected = causal.error_variance(48, np.where(np.isnan(z), np.inf, 1.0)).mean()
    for smooth in (False, True):
        out = kf.ScalarRowFilter(model, 1.0, 48, smooth=smooth).filter(z)
        assert np.isfinite(out).all()
        assert np.mean((out - x) ** 2) < 5 * expected


def test_nominal_models_that_do_not_factor_name_the_propagated_ones():
    # (4,3), ρ = 0.999, 10 % missing: the plan's models plus the weighted observations do not
    # factor in float64; the propagated models (the default) filter the same image
    model = kf.ARFieldModel([0.999, 0.999], [4, 3])
    x = eigen_sample(model, (48, 48), seed=1)
    rng = np.random.default_rng(0)
    z = x + rng.standard_normal(x.shape)
    z[rng.random(z.shape) < 0.1] = np.nan
    with pytest.raises(ValueError, match='row_models="propagated"'):
        kf.ScalarRowFilter(model, 1.0, 48, row_models="nominal").filter(z)
    assert np.isfinite(kf.ScalarRowFilter(model, 1.0, 48).filter(z)).all()


def test_bad_input():
    model = kf.ARFieldModel([0.8, 0.8], [1, 1])
    filt = kf.ScalarRowFilter(model, 1.0, 6)
    z = np.zeros((5, 6))
    with pytest.raises(ValueError, match="broadcast"):
        filt.filter(z, noise_var=np.ones((5, 5)))
    for bad in (-1.0, 0.0, np.nan):
        with pytest.raises(ValueError, match="noise_var"):
            filt.filter(z, noise_var=bad)
    inf = z.copy()
    inf[1, 1] = np.inf
    with pytest.raises(ValueError, match="infinite"):
        filt.filter(inf)
    with pytest.raises(ValueError, match="modes"):
        kf.ScalarRowFilter(model, 1.0, 6, modes="fourier")
    with pytest.raises(ValueError, match="NaN"):
        kf.VectorRowFilter(model, 1.0, 6).filter(np.full((5, 6), np.nan))
    with pytest.raises(ValueError, match="adaptive"), pytest.warns(DeprecationWarning):
        kf.denoise(np.random.default_rng(0).standard_normal((8, 8)), method="vector", adaptive=True)
    for window in (4, 0, -3):
        with pytest.raises(ValueError, match="window"):
            local_moments(z, window)
    with pytest.raises(TypeError, match="window"):
        local_moments(z, 2.5)
    with pytest.raises(ValueError, match="infinite"):
        local_moments(np.full((4, 4), np.inf), 3)
    noisy = np.random.default_rng(0).standard_normal((8, 8))
    with pytest.raises(ValueError, match="window"):
        kf.denoise(noisy, window=4)
    with pytest.raises(ValueError, match="2-axis"):
        kf.denoise(noisy, model=kf.ARFieldModel([0.7], [1]))
    holes = np.where(noisy > 1, np.nan, noisy)
    with pytest.raises(ValueError, match="NaN"):
        kf.denoise(holes, noise_var=1.0, method="vector")
    for method in ("adaptive", "stationary", "auto"):
        with pytest.raises(ValueError, match="every pixel is NaN"):
            kf.denoise(np.full((8, 8), np.nan), noise_var=1.0, method=method)
    with pytest.raises(ValueError, match="missing"):
        kf.estimate_noise_var(np.where(np.add.outer(range(8), range(8)) % 2, np.nan, noisy))
    with pytest.raises(ValueError, match="every pixel is NaN"):
        kf.model_from_noisy(np.full((8, 8), np.nan))
