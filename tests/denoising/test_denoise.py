"""denoise, its noise-level estimate and local moments, with missing (NaN) pixels and at any
magnitude; the adaptive mode against its NumPy twin and the adaptive Wiener filter."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import kalmanfield as kf
from kalmanfield.denoising.denoise import local_moments
from kalmanfield.reference.denoising.adaptive_denoise import adaptive_denoise as ref_adaptive
from kalmanfield.reference.denoising.local_moments import local_moments as ref_local_moments
from kalmanfield.reference.denoising.noise_level import haar_noise_var as ref_noise_var


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
    wide = kf.denoise(z, noise_var=0.1, method="adaptive", window=window, threads=1)
    np.testing.assert_array_equal(
        wide, kf.denoise(z, noise_var=0.1, method="adaptive", window=19, threads=1)
    )


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
    got = kf.denoise(
        z,
        noise_var=0.09,
        method="adaptive",
        detail_model=model,
        smooth=smooth,
        window=2 * radius + 1,
    )
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
    got = kf.denoise(
        z, noise_var=0.09, method="adaptive", smooth=smooth, window=5, row_models=row_models
    )
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
    method = "adaptive" if adaptive else "stationary"
    got = kf.denoise(holes, method=method)
    complete = kf.denoise(z, method=method)
    assert np.mean((got - clean)[missing] ** 2) < 0.6 * 0.01
    observed = np.mean((got - clean)[~missing] ** 2)
    assert observed < 1.1 * np.mean((complete - clean)[~missing] ** 2)


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
    first = kf.denoise(small, noise_var=0.5, method="adaptive")
    large = np.cumsum(rng.standard_normal((90, 70)), axis=1)
    large[rng.random(large.shape) < 0.3] = np.nan
    large[10:40, 10:40] = np.nan
    assert np.all(np.isfinite(kf.denoise(large, noise_var=0.5, method="adaptive")))
    np.testing.assert_array_equal(kf.denoise(small, noise_var=0.5, method="adaptive"), first)
    again = kf.denoise(small, noise_var=0.5, method="adaptive", threads=2)
    np.testing.assert_array_equal(again, first)


def test_a_stack_frame_with_no_observed_pixel():
    """The stationary mode returns such a frame as the mean and the other frames as alone
    (the frames are independent); the adaptive mode has no moments there and refuses."""
    model = kf.ARFieldModel([0.8, 0.9], [1, 1])
    rng = np.random.default_rng(3)
    z = np.stack([model.sample((24, 32), seed=s) for s in range(3)])
    z += 0.7 * rng.standard_normal(z.shape)
    z[1] = np.nan
    out = kf.denoise(z, noise_var=0.49, model=model, mean=0.25)
    np.testing.assert_array_equal(out[1], np.full((24, 32), 0.25))
    for f in (0, 2):
        alone = kf.denoise(z[f], noise_var=0.49, model=model, mean=0.25)
        np.testing.assert_allclose(out[f], alone, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="no observed pixel"):
        kf.denoise(z, noise_var=0.49, method="adaptive")


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


@pytest.mark.parametrize("method", ["adaptive", "stationary", "auto"])
def test_denoise_of_data_of_any_magnitude(method):
    """Scale-equivariant to the bit (a power of two): the adaptive mode lost 1e-4 of its
    precision at 1e-160 and refused 1e153 (its box moments overflowed), the stationary one
    refused both (σ beyond its range)."""
    model = kf.ARFieldModel([0.95, 0.95], [1, 1])
    z = model.sample((24, 30), seed=1) + 0.3 * np.random.default_rng(2).standard_normal((24, 30))
    unit = kf.denoise(z, method=method)
    for k in (-1000, -530, 510, 1000):
        np.testing.assert_array_equal(kf.denoise(np.ldexp(z, k), method=method), np.ldexp(unit, k))
    field = {} if method == "adaptive" else {"model": model}
    scaled_field = (
        {} if method == "adaptive" else {"model": kf.ARFieldModel(model.rho, model.order, 2.0**450)}
    )
    given = kf.denoise(z, noise_var=0.09, method=method, mean=0.5, **field)
    scaled = kf.denoise(
        np.ldexp(z, 450),
        noise_var=0.09 * 2.0**900,
        method=method,
        mean=2.0**450 * 0.5,
        **scaled_field,
    )
    np.testing.assert_array_equal(scaled, np.ldexp(given, 450))
    with pytest.raises(ValueError, match="overflow float64"):  # noise_var 2^-1200 of z²
        kf.denoise(np.ldexp(z, 600), noise_var=1.0, method=method)


@pytest.mark.parametrize("method", ["adaptive", "stationary"])
@pytest.mark.parametrize(
    "mean,exc", [(np.nan, ValueError), (np.inf, ValueError), ("0", TypeError), (1j, TypeError)]
)
def test_denoise_checks_mean_in_both_modes(method, mean, exc):
    """(the adaptive mode ignored an invalid mean silently; the stationary one parsed "0")"""
    z = np.random.default_rng(3).standard_normal((10, 12))
    with pytest.raises(exc, match="mean must"):
        kf.denoise(z, noise_var=0.5, mean=mean, method=method)
