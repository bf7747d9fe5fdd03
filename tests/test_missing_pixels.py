"""ScalarRowFilter with per-pixel noise variances and missing (NaN) pixels, the Toeplitz mode
set, local_moments and the adaptive denoise (SPEC §2.3 generalised; README "denoise")."""

import pickle

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import kalmanfield as kf
from kalmanfield.denoise import local_moments
from kalmanfield.reference import row_filters as ref
from kalmanfield.reference.adaptive_denoise import adaptive_denoise as ref_adaptive
from kalmanfield.reference.local_moments import local_moments as ref_local_moments
from kalmanfield.reference.noise_level import haar_noise_var as ref_noise_var

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


@pytest.mark.parametrize("shape,window", [((7, 9), 5), ((30, 17), 9), ((4, 40), 3), ((5, 5), 1)])
def test_local_moments_equal_reference_and_brute_force(shape, window):
    z = np.random.default_rng(0).uniform(100, 101, shape)
    mean, var = local_moments(z, window)
    want_mean, want_var = ref_local_moments(z, window // 2)
    np.testing.assert_allclose(mean, want_mean, atol=1e-12)
    np.testing.assert_allclose(var, want_var, atol=1e-12)
    r = window // 2
    for i, j in [(0, 0), (shape[0] // 2, shape[1] // 2), (shape[0] - 1, shape[1] - 1)]:
        box = z[max(i - r, 0) : i + r + 1, max(j - r, 0) : j + r + 1]
        assert mean[i, j] == pytest.approx(box.mean(), abs=1e-12)
        assert var[i, j] == pytest.approx(box.var(), abs=1e-12)


@pytest.mark.parametrize("window", [41, 2**28 + 1, 2**64 + 1, 2**80 + 1])
def test_a_window_wider_than_the_image_covers_it(window):
    """(the running sums were sized by the window: an abort at 2**28, a hang at 2**64)"""
    z = np.random.default_rng(2).standard_normal((6, 9))
    mean, var = local_moments(z, window)
    np.testing.assert_allclose(mean, np.full(z.shape, z.mean()), atol=1e-12)
    np.testing.assert_allclose(var, np.full(z.shape, z.var()), atol=1e-12)
    wide = kf.denoise(z, 0.1, window=window, threads=1)
    np.testing.assert_array_equal(wide, kf.denoise(z, 0.1, window=19, threads=1))


def test_pixels_whose_moments_overflow_are_refused_not_a_hang():
    """(NaN box moments were widened for ever)"""
    with pytest.raises(ValueError, match="overflow float64"):
        kf.denoise(np.full((2, 2), 1e308), noise_var=1.0, threads=1)


def test_local_moments_of_a_stack():
    z = np.random.default_rng(1).standard_normal((3, 8, 6))
    mean, var = local_moments(z, 3)
    for f in range(3):
        m, v = ref_local_moments(z[f], 1)
        np.testing.assert_allclose(mean[f], m, atol=1e-12)
        np.testing.assert_allclose(var[f], v, atol=1e-12)


@given(
    arrays(np.float64, st.tuples(st.integers(1, 9), st.integers(1, 9)), elements=st.floats(-5, 5)),
    arrays(np.bool_, 81),
    st.integers(0, 3),
)
def test_local_moments_with_missing_pixels_equal_reference_and_brute_force(z, holes, radius):
    """NaN pixels are left out of the box; a box without an observed pixel is NaN."""
    z = np.where(holes[: z.size].reshape(z.shape), np.nan, z)
    mean, var = local_moments(z, 2 * radius + 1)
    want_mean, want_var = ref_local_moments(z, radius)
    np.testing.assert_allclose(mean, want_mean, atol=1e-12)
    np.testing.assert_allclose(var, want_var, atol=1e-11)
    for i, j in np.ndindex(z.shape):
        box = z[max(i - radius, 0) : i + radius + 1, max(j - radius, 0) : j + radius + 1]
        box = box[~np.isnan(box)]
        if box.size == 0:
            assert np.isnan(mean[i, j]) and np.isnan(var[i, j])
        else:
            assert mean[i, j] == pytest.approx(box.mean(), abs=1e-12)
            assert var[i, j] == pytest.approx(box.var(), abs=1e-11)


def psnr(estimate, clean):
    return 10 * np.log10(1.0 / np.mean((estimate - clean) ** 2))


def test_row_models_are_checked_and_pickled():
    model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    with pytest.raises(ValueError, match="'auto', 'propagated', 'nominal' or 'implied'"):
        kf.ScalarRowFilter(model, 1.0, 8, row_models="exact")
    with pytest.raises(ValueError, match="row_models must be 'propagated', 'nominal' or 'impl"):
        kf.denoise(np.ones((8, 8)), 0.1, row_models="plan")
    for row_models in ("nominal", "implied"):
        filt = kf.ScalarRowFilter(model, 1.0, 8, smooth=True, row_models=row_models)
        assert pickle.loads(pickle.dumps(filt)).row_models == row_models
    assert kf.ScalarRowFilter(model, 1.0, 8).row_models == "propagated"


@pytest.mark.parametrize("name", ["camera", "coins"])
def test_adaptive_denoise_beats_the_adaptive_wiener_filter(name):
    """The issue's goal on natural images: at least the PSNR of scipy.signal.wiener (5×5)."""
    data = pytest.importorskip("skimage.data")
    wiener = pytest.importorskip("scipy.signal").wiener
    clean = getattr(data, name)() / 255.0
    z = clean + 0.1 * np.random.default_rng(0).standard_normal(clean.shape)
    ours, theirs = psnr(kf.denoise(z), clean), psnr(wiener(z, (5, 5)), clean)
    assert ours > theirs + 0.5, (ours, theirs)
    assert psnr(kf.denoise(z, noise_var=0.01), clean) > theirs + 0.5


@pytest.mark.parametrize("smooth", [False, True])
@pytest.mark.parametrize("rho,order,radius", [((0.7, 0.7), (1, 1), 2), ((0.8, 0.6), (2, 1), 1)])
def test_adaptive_denoise_equals_reference(rho, order, radius, smooth):
    """The Rust kernel of the adaptive mode vs its NumPy twin, on an image with edges."""
    rng = np.random.default_rng(sum(order))
    clean = np.add.outer(np.sin(0.3 * np.arange(19)), 2.0 * (np.arange(23) > 11))
    z = clean + 0.3 * rng.standard_normal(clean.shape)
    model = kf.ARFieldModel(list(rho), list(order))
    got = kf.denoise(z, noise_var=0.09, model=model, smooth=smooth, window=2 * radius + 1)
    want = ref_adaptive(z, 0.09, rho, order, radius, smooth=smooth)
    np.testing.assert_allclose(got, want, atol=1e-10, rtol=0)
    assert np.mean((got - clean) ** 2) < 0.5 * np.mean((z - clean) ** 2)


@pytest.mark.parametrize(
    ("smooth", "row_models"), [(False, "nominal"), (True, "nominal"), (True, "propagated")]
)
def test_adaptive_denoise_with_missing_pixels_equals_reference(smooth, row_models):
    """Scattered NaN pixels and a hole wider than the window (whose centre's boxes are
    widened): Rust kernel == NumPy twin, and the fill is close to the clean image."""
    rng = np.random.default_rng(7)
    clean = np.add.outer(np.sin(0.3 * np.arange(29)), 2.0 * (np.arange(31) > 15))
    z = clean + 0.3 * rng.standard_normal(clean.shape)
    z[rng.random(z.shape) < 0.2] = np.nan
    z[5:14, 3:12] = np.nan
    got = kf.denoise(z, noise_var=0.09, smooth=smooth, window=5, row_models=row_models)
    want = ref_adaptive(z, 0.09, (0.7, 0.7), (1, 1), 2, smooth=smooth, row_models=row_models)
    np.testing.assert_allclose(got, want, atol=1e-10, rtol=0)
    missing = np.isnan(z)
    assert np.all(np.isfinite(got))
    # the fill (mostly in smooth areas) is better than an observation would have been
    assert np.mean((got - clean)[missing] ** 2) < 0.09


@pytest.mark.parametrize("adaptive", [True, False])
def test_denoise_fills_missing_pixels_of_a_natural_image(adaptive):
    """camera, σ = 0.1, 20 % of the pixels missing: the filled pixels' MSE is well under the
    noise variance, and the observed pixels lose < 10 % MSE against the complete image
    (measured: 0.35 / 0.53 σ² filled, +5 % / +6 % observed, adaptive / stationary)."""
    data = pytest.importorskip("skimage.data")
    clean = data.camera()[::2, ::2] / 255.0
    rng = np.random.default_rng(0)
    z = clean + 0.1 * rng.standard_normal(clean.shape)
    holes = np.where(rng.random(z.shape) < 0.2, np.nan, z)
    missing = np.isnan(holes)
    got = kf.denoise(holes, adaptive=adaptive)
    complete = kf.denoise(z, adaptive=adaptive)
    assert np.mean((got - clean)[missing] ** 2) < 0.6 * 0.01
    observed = np.mean((got - clean)[~missing] ** 2)
    assert observed < 1.1 * np.mean((complete - clean)[~missing] ** 2)


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


def test_missing_pixels_in_the_estimates():
    """estimate_noise_var and model_from_noisy leave NaN pixels out: 10 % missing pixels
    change their estimates by far less than their own error (the fitted noise variance is
    0.35 for the true 0.25 either way)."""
    model = kf.ARFieldModel([0.9, 0.8], [1, 1])
    rng = np.random.default_rng(2)
    z = model.sample((120, 100), seed=2) + 0.5 * rng.standard_normal((120, 100))
    holes = np.where(rng.random(z.shape) < 0.1, np.nan, z)
    assert kf.estimate_noise_var(holes) == pytest.approx(kf.estimate_noise_var(z), rel=0.05)
    fitted, mean, noise = kf.model_from_noisy(holes)
    want, want_mean, want_noise = kf.model_from_noisy(z)
    assert mean == pytest.approx(want_mean, abs=0.01)
    assert noise == pytest.approx(want_noise, rel=0.05)
    assert fitted.order == want.order
    np.testing.assert_allclose(fitted.rho, want.rho, atol=0.01)


@given(
    shape=st.tuples(st.integers(1, 3), st.integers(2, 9), st.integers(2, 9)),
    seed=st.integers(0, 2**32 - 1),
    missing=st.sampled_from([0.0, 0.2, 0.6]),
)
def test_noise_estimate_equals_reference(shape, seed, missing):
    """The Rust Haar-MAD kernel == its NumPy twin, bit for bit: odd sizes (the last row or
    column left out), stacks pooled, NaN blocks left out, odd and even counts."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal(shape) * rng.uniform(0.1, 10.0)
    z[rng.random(shape) < missing] = np.nan
    for image in (z, z[0], z[np.newaxis]):
        try:
            want = ref_noise_var(image)
        except ValueError:
            with pytest.raises(ValueError, match="no 2×2 block without a NaN"):
                kf.estimate_noise_var(image)
            continue
        assert kf.estimate_noise_var(image) == want


def test_adaptive_denoise_of_a_stack_is_per_frame():
    rng = np.random.default_rng(4)
    frames = np.cumsum(rng.standard_normal((2, 24, 20)), axis=2)
    stack = kf.denoise(frames, noise_var=0.5)
    for f in range(2):
        np.testing.assert_array_equal(stack[f], kf.denoise(frames[f], noise_var=0.5))
    # frames run in parallel: the same bits with one thread
    np.testing.assert_array_equal(stack, kf.denoise(frames, noise_var=0.5, threads=1))


def test_adaptive_denoise_gives_the_same_bits_whatever_ran_before():
    """The kernel reuses its frame-sized buffers between calls on a thread
    (rust/src/scratch.rs): nothing of an earlier, larger call with missing pixels and widened
    boxes (two more buffers) carries over, and threads=k gives the same bits."""
    rng = np.random.default_rng(5)
    small = np.cumsum(rng.standard_normal((30, 40)), axis=1)
    first = kf.denoise(small, noise_var=0.5)
    large = np.cumsum(rng.standard_normal((90, 70)), axis=1)
    large[rng.random(large.shape) < 0.3] = np.nan
    large[10:40, 10:40] = np.nan
    assert np.all(np.isfinite(kf.denoise(large, noise_var=0.5)))
    np.testing.assert_array_equal(kf.denoise(small, noise_var=0.5), first)
    np.testing.assert_array_equal(kf.denoise(small, noise_var=0.5, threads=2), first)


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
    with pytest.raises(ValueError, match="adaptive"):
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
    for adaptive in (True, False):
        with pytest.raises(ValueError, match="every pixel is NaN"):
            kf.denoise(np.full((8, 8), np.nan), noise_var=1.0, adaptive=adaptive)
    with pytest.raises(ValueError, match="missing"):
        kf.estimate_noise_var(np.where(np.add.outer(range(8), range(8)) % 2, np.nan, noisy))
    with pytest.raises(ValueError, match="every pixel is NaN"):
        kf.model_from_noisy(np.full((8, 8), np.nan))


def test_a_stack_frame_with_no_observed_pixel():
    """The stationary mode returns such a frame as the mean and the other frames as alone
    (the frames are independent); the adaptive mode has no moments there and refuses."""
    model = kf.ARFieldModel([0.8, 0.9], [1, 1])
    rng = np.random.default_rng(3)
    z = np.stack([model.sample((24, 32), seed=s) for s in range(3)])
    z += 0.7 * rng.standard_normal(z.shape)
    z[1] = np.nan
    out = kf.denoise(z, 0.49, model, adaptive=False, mean=0.25)
    np.testing.assert_array_equal(out[1], np.full((24, 32), 0.25))
    for f in (0, 2):
        alone = kf.denoise(z[f], 0.49, model, adaptive=False, mean=0.25)
        np.testing.assert_allclose(out[f], alone, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="no observed pixel"):
        kf.denoise(z, 0.49, model)


# ------------------------------------------------------------------ issue 49, items 8 and 13
@pytest.mark.parametrize("holes", [False, True])
def test_local_moments_of_data_of_any_magnitude(holes):
    """(variance 0 everywhere for data × 1e160, NaN means for × 1e306, silently). Scaled by a
    power of two the moments are the unit data's, scaled: exact; variances beyond float64
    are the "rescale" ValueError of estimate_noise_var and identify."""
    z = np.random.default_rng(5).standard_normal((2, 12, 15))
    if holes:
        z[0, 3, 4] = z[1, 7:9, 2:6] = np.nan
    mean, var = local_moments(z, 5)
    for k in (-1000, -531, -100, 300, 450, 505):  # 1e-301, 1e-160, …, 1e152
        m, v = local_moments(np.ldexp(z, k), 5)
        np.testing.assert_array_equal(m, np.ldexp(mean, k))
        np.testing.assert_array_equal(v, np.ldexp(var, 2 * k))  # (subnormal: rounded once)
    for factor in (1e160, 1e306):
        with pytest.raises(ValueError, match="overflow float64.*rescale"):
            local_moments(z * factor, 5)
    # a huge offset with deviations whose squares fit: against the twin in scaled units
    offset = 2.0**531 + np.ldexp(z[0], 480)
    m, v = local_moments(offset, 3)
    want_m, want_v = ref_local_moments(np.ldexp(offset, -531), 1)
    np.testing.assert_allclose(m, np.ldexp(want_m, 531), rtol=1e-15)
    np.testing.assert_allclose(v, np.ldexp(want_v, 1062), rtol=1e-9)
    assert np.isfinite(v[~np.isnan(v)]).all()


@pytest.mark.parametrize("adaptive", [True, False])
def test_denoise_of_data_of_any_magnitude(adaptive):
    """Scale-equivariant to the bit (a power of two): the adaptive mode lost 1e-4 of its
    precision at 1e-160 and refused 1e153 (its box moments overflowed), the stationary one
    refused both (σ beyond its range)."""
    model = kf.ARFieldModel([0.95, 0.95], [1, 1])
    z = model.sample((24, 30), seed=1) + 0.3 * np.random.default_rng(2).standard_normal((24, 30))
    unit = kf.denoise(z, adaptive=adaptive)
    for k in (-1000, -530, 510, 1000):
        np.testing.assert_array_equal(
            kf.denoise(np.ldexp(z, k), adaptive=adaptive), np.ldexp(unit, k)
        )
    given = kf.denoise(z, 0.09, model, mean=0.5, adaptive=adaptive)
    scaled = kf.denoise(
        np.ldexp(z, 450),
        0.09 * 2.0**900,
        model if adaptive else kf.ARFieldModel(model.rho, model.order, 2.0**450),
        mean=2.0**450 * 0.5,
        adaptive=adaptive,
    )
    np.testing.assert_array_equal(scaled, np.ldexp(given, 450))
    with pytest.raises(ValueError, match="overflow float64"):  # noise_var 2^-1200 of z²
        kf.denoise(np.ldexp(z, 600), 1.0, adaptive=adaptive)


@pytest.mark.parametrize("adaptive", [True, False])
@pytest.mark.parametrize(
    "mean,exc", [(np.nan, ValueError), (np.inf, ValueError), ("0", TypeError), (1j, TypeError)]
)
def test_denoise_checks_mean_in_both_modes(adaptive, mean, exc):
    """(the adaptive mode ignored an invalid mean silently; the stationary one parsed "0")"""
    z = np.random.default_rng(3).standard_normal((10, 12))
    with pytest.raises(exc, match="mean must"):
        kf.denoise(z, 0.5, mean=mean, adaptive=adaptive)
