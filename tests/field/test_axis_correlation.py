"""R(k), β and the template against independent computations (method page *Random fields*,
§1.1–1.2)."""

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given
from hypothesis import strategies as st

import kalmanfield as kf
from kalmanfield import _core
from kalmanfield import reference as ref


def impulse_correlation(rho: float, n: int, lags: np.ndarray) -> np.ndarray:
    """R(k) = Σ h_i h_{i+k} / Σ h_i² with h the impulse response of (1 - ρ z⁻¹)^{-n}."""
    h = np.ones(6000)
    for i in range(1, len(h)):
        h[i] = h[i - 1] * rho * (n + i - 1) / i
    c = np.array([h[: len(h) - k] @ h[k:] for k in lags])
    return c / (h @ h)


def lyapunov_correlation(rho: float, n: int, lags: np.ndarray) -> np.ndarray:
    """R(k) from the stationary covariance of the companion-form state (Lyapunov equation)."""
    alpha = ref.axis_ar_coefficients(rho, n)
    a = np.zeros((n, n))
    a[0] = alpha
    a[1:, :-1] = np.eye(n - 1)
    q = np.zeros((n, n))
    q[0, 0] = 1.0
    p = scipy.linalg.solve_discrete_lyapunov(a, q)
    out = []
    for k in lags:
        out.append((np.linalg.matrix_power(a, int(k)) @ p)[0, 0] / p[0, 0])
    return np.array(out)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
@pytest.mark.parametrize("rho", [0.2, 0.6, 0.9, 0.97])
def test_correlation_matches_impulse_and_lyapunov(n, rho):
    lags = np.arange(0, 15)
    got = kf.ARFieldModel(rho, n).correlation(lags)
    np.testing.assert_allclose(got, impulse_correlation(rho, n, lags), atol=1e-10)
    np.testing.assert_allclose(got, lyapunov_correlation(rho, n, lags), atol=1e-9)


def test_second_order_closed_form_on_real_lags():
    rho = 0.75
    r = np.linspace(-6, 6, 41)
    want = rho ** np.abs(r) * (1 + np.abs(r) * (1 - rho**2) / (1 + rho**2))
    np.testing.assert_allclose(kf.ARFieldModel(rho, 2).correlation(r), want, rtol=1e-13)


@given(
    n=st.integers(1, 6),
    rho=st.floats(0.05, 0.98),
    lags=st.lists(st.floats(-20, 20), min_size=1, max_size=8),
)
def test_rust_correlation_equals_reference(n, rho, lags):
    got = kf.ARFieldModel(rho, n).correlation(np.array(lags))
    np.testing.assert_allclose(got, ref.axis_correlation(rho, n, lags), rtol=1e-10, atol=1e-13)


@given(
    n=st.integers(1, 6),
    rhos=st.lists(st.floats(0.05, 0.995), min_size=1, max_size=5),
    lags=st.lists(st.floats(-20, 20), min_size=1, max_size=8),
)
def test_correlation_table_equals_reference(n, rhos, lags):
    """The batch of `model_from_noisy`'s fit: one row per ρ, each the reference R(lags)."""
    table = _core.axis_correlation_table(np.array(rhos), n, np.array(lags))
    assert table.shape == (len(rhos), len(lags))
    for row, rho in zip(table, rhos):
        np.testing.assert_allclose(row, ref.axis_correlation(rho, n, lags), rtol=1e-10, atol=1e-13)


def test_correlation_table_refuses_bad_input():
    lags = np.arange(3.0)
    for rhos, n, bad_lags, match in [
        ([0.5, 1.0], 1, lags, "rho"),
        ([0.5], 0, lags, "order"),
        ([0.5], 1, np.array([1.0, np.nan]), "finite"),
        ([0.5], 1, lags[::2], "contiguous"),
    ]:
        with pytest.raises(ValueError, match=match):
            _core.axis_correlation_table(np.array(rhos), n, bad_lags)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_beta_gives_the_requested_variance(n):
    rho, sigma = 0.8, 1.7
    model = kf.ARFieldModel([rho, 0.5], [n, 1], sigma)
    # variance of the stationary AR(n) driven by β̃ ξ is β̃² Σ h_i²
    h = np.ones(4000)
    for i in range(1, len(h)):
        h[i] = h[i - 1] * rho * (n + i - 1) / i
    bt2 = ref.beta_tilde_sq(rho, n)
    assert bt2 * (h @ h) == pytest.approx(1.0, rel=1e-10)
    assert model.beta == pytest.approx(sigma * np.sqrt(bt2 * ref.beta_tilde_sq(0.5, 1)), rel=1e-12)


def test_multi_axis_correlation_is_a_product():
    model = kf.ARFieldModel([0.9, 0.7, 0.5], [2, 1, 3], sigma=2.0)
    lags = np.array([[0, 0, 0], [1, 2, 3], [-2.5, 0.5, 1.0]])
    np.testing.assert_allclose(
        model.correlation(lags), ref.correlation(model.rho, model.order, 2.0, lags), rtol=1e-12
    )
    assert model.correlation(lags)[0] == pytest.approx(4.0)
    assert model.correlation(lags.reshape(3, 1, 3)).shape == (3, 1)


def test_template_matches_reference_and_sign_convention():
    model = kf.ARFieldModel([0.9, 0.6], [2, 3])
    c = model.coefficients()
    assert c.shape == (3, 4)
    np.testing.assert_allclose(c, ref.field.ar_field.template(model.rho, model.order), rtol=1e-14)
    assert c[0, 0] == 1.0
    # 8-point model: x = 2ρ x_{i-1} - ρ² x_{i-2} along one axis (§1.2 fix of [P 1.9])
    one = kf.ARFieldModel(0.9, 2).coefficients()
    np.testing.assert_allclose(-one[1:], [1.8, -0.81])


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_boundary_recursion_equals_reference(n):
    model = kf.ARFieldModel([0.93], [n])
    coeffs, gains = model._core.boundary(0)
    want_c, want_g = ref.boundary_recursion(0.93, n)
    # Levinson on a near-singular Toeplitz matrix (ρ = 0.93) amplifies the 1e-16 differences
    # between the two evaluations of R(k) to ~1e-10
    for a, b in zip(coeffs[:n], want_c[:n]):
        np.testing.assert_allclose(a, b, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(gains[:n], want_g[:n], rtol=1e-8)
    # the last order is the model itself (analytic values)
    np.testing.assert_allclose(coeffs[n], ref.axis_ar_coefficients(0.93, n), rtol=1e-14)
    assert gains[n] ** 2 == pytest.approx(ref.beta_tilde_sq(0.93, n), rel=1e-14)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_boundary_models_solve_yule_walker(n):
    """Each order-m boundary model solves Σ_i a_i R(i-s) = R(s), s = 1..m [P 4.3] (checked by
    an independent dense solve, to the accuracy the conditioning allows)."""
    rho = 0.8
    coeffs, gains = ref.boundary_recursion(rho, n)
    r = ref.axis_correlation(rho, n, np.arange(n + 1))
    for m in range(1, n + 1):
        toeplitz = r[np.abs(np.subtract.outer(np.arange(m), np.arange(m)))]
        np.testing.assert_allclose(coeffs[m], np.linalg.solve(toeplitz, r[1 : m + 1]), atol=1e-9)
        assert gains[m] ** 2 == pytest.approx(1 - coeffs[m] @ r[1 : m + 1], rel=1e-9)
