"""The cascade generator (method page *Random fields*, §1.2–1.3): reference twin, exact
stationarity, seeds, dtypes."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import kalmanfield as kf
from kalmanfield import reference as ref


@st.composite
def models_and_shapes(draw):
    ndim = draw(st.integers(1, 3))
    rho = draw(st.lists(st.floats(0.05, 0.95), min_size=ndim, max_size=ndim))
    order = draw(st.lists(st.integers(1, 4), min_size=ndim, max_size=ndim))
    shape = tuple(draw(st.lists(st.integers(1, 9), min_size=ndim, max_size=ndim)))
    sigma = draw(st.floats(0.1, 5.0))
    return kf.ARFieldModel(rho, order, sigma), shape


@given(models_and_shapes(), st.integers(0, 2**32))
def test_rust_equals_reference_on_identical_noise(model_shape, seed):
    """Includes 1×k lines and grids smaller than the order (only boundary models run).
    Tolerance: for ρ near 1 and order 4 the boundary (Levinson) coefficients amplify the
    1e-16 differences between the two evaluations of R(k): up to 2.4e-10 at ρ = 0.9,
    4.5e-10 at 0.93 and 5.3e-9 at 0.95 (200 seeds each, 9 × 3 grids), so 1e-8 there."""
    model, shape = model_shape
    noise = np.random.default_rng(seed).standard_normal(shape)
    got = model.sample(shape, noise=noise)
    want = ref.sample(model.rho, model.order, model.sigma, noise)
    steep = any(n == 4 and r > 0.93 for r, n in zip(model.rho, model.order))
    tol = 1e-8 if steep else 1e-9
    np.testing.assert_allclose(got, want, rtol=tol, atol=tol * model.sigma)


def test_large_grid_equals_reference_in_parallel():
    model = kf.ARFieldModel([0.9, 0.8], [2, 3], 1.3)
    noise = np.random.default_rng(0).standard_normal((300, 400))
    want = ref.sample(model.rho, model.order, model.sigma, noise)
    for threads in (1, 2):
        got = model.sample(noise.shape, noise=noise, threads=threads)
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-12)


def _empirical_covariance(model, shape, reps, seed):
    rng = np.random.default_rng(seed)
    seeds = rng.integers(0, 2**63, size=reps)
    x = np.stack([model.sample(shape, seed=int(s)).ravel() for s in seeds])
    return x.T @ x / reps, x


@pytest.mark.parametrize(
    "rho,order", [([0.9, 0.7], [1, 1]), ([0.85, 0.9], [2, 3]), ([0.6, 0.95], [4, 2])]
)
def test_exactly_stationary_at_edges_and_corners(rho, order):
    """Empirical covariance of every pair of points of a small grid equals σ² Π R_k, corners and
    edges included, within 5 standard errors (Var of a sample covariance of a Gaussian pair is
    (C_ii C_jj + C_ij²)/M)."""
    sigma, shape, reps = 1.5, (5, 6), 20000
    model = kf.ARFieldModel(rho, order, sigma)
    emp, _ = _empirical_covariance(model, shape, reps, seed=1)
    idx = np.array(np.unravel_index(np.arange(np.prod(shape)), shape)).T
    lags = idx[:, None, :] - idx[None, :, :]
    want = model.correlation(lags)
    se = np.sqrt((sigma**4 + want**2) / reps)
    z = (emp - want) / se
    assert np.abs(z).max() < 5.0, f"max |z| = {np.abs(z).max():.2f}"
    # and a recursion started from zeros would fail this test: the corner variance is β̃²σ²
    assert abs(emp[0, 0] - sigma**2) < 5 * se[0, 0]


def test_three_axes_corner_covariances():
    model = kf.ARFieldModel([0.8, 0.9, 0.7], [2, 1, 2], 1.0)
    shape, reps = (3, 3, 4), 20000
    emp, _ = _empirical_covariance(model, shape, reps, seed=2)
    idx = np.array(np.unravel_index(np.arange(np.prod(shape)), shape)).T
    want = model.correlation(idx[:, None, :] - idx[None, :, :])
    z = (emp - want) / np.sqrt((1 + want**2) / reps)
    assert np.abs(z).max() < 5.0


def test_covariance_of_the_reference_is_exact():
    """The cascade is a linear map L of the noise: L Lᵀ must equal the model covariance exactly
    (no sampling error), which pins down every boundary coefficient."""
    model = kf.ARFieldModel([0.9, 0.75], [3, 2], 2.0)
    shape = (4, 5)
    size = int(np.prod(shape))
    columns = [
        model.sample(shape, noise=np.eye(size)[k].reshape(shape)).ravel() for k in range(size)
    ]
    lmat = np.array(columns).T
    idx = np.array(np.unravel_index(np.arange(size), shape)).T
    want = model.correlation(idx[:, None, :] - idx[None, :, :])
    np.testing.assert_allclose(lmat @ lmat.T, want, rtol=1e-9, atol=1e-12)


def test_seeds_are_reproducible_and_thread_independent():
    model = kf.ARFieldModel([0.9, 0.8], [2, 2])
    a = model.sample((700, 500), seed=42, threads=1)
    b = model.sample((700, 500), seed=42, threads=2)
    c = model.sample((700, 500), seed=42)
    assert np.array_equal(a, b) and np.array_equal(a, c)
    assert not np.array_equal(a, model.sample((700, 500), seed=43))
    gen_a = model.sample((4, 4), seed=np.random.default_rng(5))
    gen_b = model.sample((4, 4), seed=np.random.default_rng(5))
    assert np.array_equal(gen_a, gen_b)
    assert not np.array_equal(model.sample((4, 4)), model.sample((4, 4)))  # fresh entropy


def test_float32_path_matches_float64():
    model = kf.ARFieldModel([0.95, 0.9], [2, 2], 3.0)
    x64 = model.sample((300, 200), seed=3)
    x32 = model.sample((300, 200), seed=3, dtype=np.float32)
    assert x32.dtype == np.float32
    np.testing.assert_allclose(x32, x64, rtol=0, atol=1e-4 * 3.0)


def test_marginal_variance_and_lag_one_correlation_on_a_large_field():
    """One big field: sample variance and lag-1 correlations along both axes agree with the
    model (tolerance from the effective number of independent samples, generous)."""
    model = kf.ARFieldModel([0.8, 0.6], [2, 1], 2.0)
    x = model.sample((1024, 1024), seed=7)
    assert x.var() == pytest.approx(4.0, rel=0.03)
    r_y = np.mean(x[1:] * x[:-1]) / 4.0
    r_x = np.mean(x[:, 1:] * x[:, :-1]) / 4.0
    assert r_y == pytest.approx(model.correlation([1, 0]) / 4.0, abs=0.02)
    assert r_x == pytest.approx(0.6, abs=0.02)


def test_product_field_equals_reference_and_has_the_model_covariance():
    model = kf.ARFieldModel([0.8, 0.7], [2, 1], 1.5)
    rng = np.random.default_rng(0)
    noises = [rng.standard_normal(6), rng.standard_normal(9)]
    got = kf.sample_product_field(model, (6, 9), noise=noises)
    np.testing.assert_allclose(
        got, ref.product_field(model.rho, model.order, 1.5, noises), rtol=1e-12
    )
    reps = 20000
    x = np.stack([kf.sample_product_field(model, (3, 3), seed=s).ravel() for s in range(reps)])
    emp = x.T @ x / reps
    idx = np.array(np.unravel_index(np.arange(9), (3, 3))).T
    want = model.correlation(idx[:, None, :] - idx[None, :, :])
    # product of two independent N(0,1): E[x⁴] = 9 σ⁴, so Var(x_i x_j) ≤ 9 σ⁴
    se = np.sqrt(9 * 1.5**4 / reps)
    assert np.abs(emp - want).max() < 5 * se
    kurtosis = np.mean(x[:, 4] ** 4) / np.mean(x[:, 4] ** 2) ** 2
    assert kurtosis == pytest.approx(9.0, rel=0.15)  # non-Gaussian, as §1.4 says


def test_product_field_threads_and_dtype():
    model = kf.ARFieldModel([0.8, 0.7, 0.9], [1, 2, 1])
    a = kf.sample_product_field(model, (40, 50, 60), seed=1, threads=1)
    b = kf.sample_product_field(model, (40, 50, 60), seed=1, threads=2)
    assert np.array_equal(a, b)
    c = kf.sample_product_field(model, (40, 50, 60), seed=1, dtype=np.float32)
    np.testing.assert_allclose(c, a, rtol=1e-6, atol=1e-6)


def test_models_are_values():
    a = kf.ARFieldModel([0.9, 0.8], [1, 2], sigma=2.0)
    same = kf.ARFieldModel((0.9, 0.8), (1, 2), sigma=2.0)
    other = kf.ARFieldModel([0.9, 0.8], [1, 2], sigma=1.0)
    assert a.ndim == 2 and kf.ARFieldModel([0.5] * 3, 1).ndim == 3
    assert a == same and hash(a) == hash(same) and a != other
    assert len({a, same, other}) == 2  # usable as set members and dict keys


# ------------------------------------------------------------------ issue 49, item 9
@pytest.mark.parametrize("dtype,big", [(np.float64, 1e308), (np.float32, 1e38)])
def test_given_noise_whose_field_overflows_is_refused(dtype, big):
    """(sample(shape, noise=np.full(shape, 1e308)) returned NaN and inf, float32 too)"""
    model = kf.ARFieldModel([0.9, 0.8], [2, 2])
    with pytest.raises(ValueError, match="given noise overflows"):
        model.sample((6, 7), noise=np.full((6, 7), big), dtype=dtype)
    # noise far above standard normal but whose field fits is the linear image of the unit one
    noise = np.random.default_rng(1).standard_normal((6, 7))
    np.testing.assert_allclose(
        model.sample((6, 7), noise=noise * 2.0**900), model.sample((6, 7), noise=noise) * 2.0**900
    )
    with pytest.raises(ValueError, match="given noise overflows"):
        kf.sample_product_field(
            model, (6, 7), noise=[np.full(6, 1e200), np.full(7, 1e200)], dtype=dtype
        )
    assert np.isfinite(
        kf.sample_product_field(model, (6, 7), noise=[np.full(6, 1e100), np.full(7, 1e100)])
    ).all()
