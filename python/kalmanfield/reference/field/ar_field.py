"""NumPy reference of the AR random-field kernels (method page *Random fields*, §1.1–1.5).

Twin of the Rust modules axis_model, stationary_start, field_model, cascade, product_field and
anisotropy. Written straight from the formulas, with different numerical routes where that
makes the cross-check stronger: R(k) from [P 2.9] term by term, the boundary models by solving
each Yule–Walker system directly (not Levinson), A_τ by Gauss–Laguerre in t and a midpoint
rule over the sphere.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import comb, factorial, sqrt

import numpy as np


def axis_ar_coefficients(rho: float, n: int) -> np.ndarray:
    """α_j = (-1)^{j+1} C(n,j) ρ^j, j = 1..n  [P 2.8]."""
    return np.array([(-1) ** (j + 1) * comb(n, j) * rho**j for j in range(1, n + 1)])


def beta_tilde_sq(rho: float, n: int) -> float:
    """β̃² = (1-ρ²)^{2n-1} / Σ_l (C(n-1,l) ρ^l)²  [P 2.11, 2.12]."""
    return (1 - rho**2) ** (2 * n - 1) / sum((comb(n - 1, ell) * rho**ell) ** 2 for ell in range(n))


def axis_correlation(rho: float, n: int, lags: np.ndarray) -> np.ndarray:
    """R(k) of [P 2.9, 2.10]; (n+k-1)!/(n+k-l-1)! evaluated as the product Π_{i<l}(n+k-1-i),
    which extends R to real lags."""
    k = np.abs(np.asarray(lags, dtype=float))
    b2 = beta_tilde_sq(rho, n)
    total = np.zeros_like(k)
    for ell in range(n):
        rising = np.ones_like(k)
        for i in range(ell):
            rising = rising * (n + k - 1 - i)
        const = factorial(2 * n - ell - 2) / (
            factorial(ell) * factorial(n - 1) * factorial(n - ell - 1)
        )
        total = total + const * rising * rho ** (2 * (n - ell - 1)) / (1 - rho**2) ** (
            2 * n - ell - 1
        )
    decay = rho**k
    with np.errstate(invalid="ignore"):  # a far lag's polynomial may overflow: 0 · inf
        return np.where(decay == 0.0, 0.0, b2 * decay * total)


def correlation(rho: Sequence[float], order: Sequence[int], sigma: float, lags) -> np.ndarray:
    """σ² Π_k R_k(r_k) for lags of shape (..., N)  [P 2.17]."""
    lags = np.asarray(lags, dtype=float)
    out = np.full(lags.shape[:-1], sigma**2)
    for k, (r, n) in enumerate(zip(rho, order)):
        out = out * axis_correlation(r, n, lags[..., k])
    return out


def template(rho: Sequence[float], order: Sequence[int]) -> np.ndarray:
    """c_j̄ = Π_k (-1)^{j_k} C(n_k, j_k) ρ_k^{j_k}  [P 2.14]."""
    out = np.ones(())
    for r, n in zip(rho, order):
        c = np.array([(-1) ** j * comb(n, j) * r**j for j in range(n + 1)])
        out = np.multiply.outer(out, c)
    return out


def _levinson(rho: float, n: int) -> tuple[list[np.ndarray], list[float]]:
    """Coefficients a^{(m)} and prediction errors b_m², m = 0..n, by Levinson–Durbin."""
    return _levinson_of(axis_correlation(rho, n, np.arange(n + 1)))


def _levinson_of(r: np.ndarray) -> tuple[list[np.ndarray], list[float]]:
    """Levinson–Durbin on the correlations r (lags 0..n)."""
    n = len(r) - 1
    coeffs, errors = [np.zeros(0)], [float(r[0])]
    for m in range(1, n + 1):
        prev = coeffs[-1]
        k = (r[m] - prev @ r[m - 1 : 0 : -1]) / errors[-1]
        coeffs.append(np.append(prev - k * prev[::-1], k))
        errors.append(errors[-1] * (1 - k * k))
    return coeffs, errors


def boundary_recursion(rho: float, n: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Coefficients a^{(m)} and gains b_m, m = 0..n, of the stationary start (§1.3):
    Σ_i a_i R(i-s) = R(s), s = 1..m, b_m² = 1 - Σ_i a_i R(i)  [P 4.3, 4.4], solved order by
    order with the Levinson–Durbin recursion (as the kernel does: for ρ near 1 these Toeplitz
    systems are ill-conditioned and two different solvers would differ in the 8th digit)."""
    coeffs, errors = _levinson(rho, n)
    return coeffs, np.sqrt(errors)


def stationary_start(rho: float, n: int) -> tuple[list[np.ndarray], np.ndarray]:
    """The start the generator runs: :func:`boundary_recursion` for orders 0..n − 1, the
    model's analytic coefficients and β̃ for order n. ValueError (as the kernel) when a
    prediction error of orders 0..n − 1 rounds to ≤ 0: the start is beyond float64."""
    coeffs, errors = _levinson(rho, n)
    for m, e in enumerate(errors[:n]):
        if not e > 0:
            raise ValueError(
                f"the exactly stationary start of an axis with rho = {rho} and multiplicity "
                f"{n} is beyond float64: its order-{m} prediction error rounds to {e:.1e}"
            )
    _check_start_accuracy(rho, n, errors)
    if 1e-5 < np.finfo(np.float64).eps / sqrt(beta_tilde_sq(rho, n)):
        raise ValueError(
            f"an axis with rho = {rho} and multiplicity {n} amplifies the rounding of float64 "
            "recursions beyond 1e-3 σ: lower rho or the multiplicity"
        )
    coeffs[n], errors[n] = axis_ar_coefficients(rho, n), beta_tilde_sq(rho, n)
    return coeffs, np.sqrt(errors)


def _check_start_accuracy(rho: float, n: int, errors: list[float]) -> None:
    """ValueError (as the kernel) when the start's prediction errors of orders 0..n − 1
    change by more than 10 % (relative) under R(k)·(1 ± 4ε) in three sign patterns."""
    r = axis_correlation(rho, n, np.arange(n + 1))
    k = np.arange(n + 1)
    eps = np.finfo(np.float64).eps
    base = np.array(errors[:n])
    sensitivity = 0.0
    patterns = [np.where(k % 2, -1.0, 1.0), np.where(k % 2, 0.0, 1.0)]
    patterns.append(np.where(k // 2 % 2, -1.0, 1.0))
    for sign in patterns:
        moved = np.array(_levinson_of(r * (1 + 4 * eps * sign))[1][:n])
        with np.errstate(invalid="ignore", divide="ignore"):
            change = np.abs((moved - base) / base)
        sensitivity = max(sensitivity, float(np.max(np.where(np.isnan(change), np.inf, change))))
    if sensitivity > 0.1:
        raise ValueError(
            f"the exactly stationary start of an axis with rho = {rho} and multiplicity {n} is "
            f"beyond float64: its prediction errors change by {sensitivity:.1e} (relative) when "
            "the correlations move by 4 ulps"
        )


def _recurse_axis(x: np.ndarray, axis: int, rho: float, n: int, scale: float = 1.0) -> np.ndarray:
    """Stationary-start recursion along `axis`, vectorised over the other axes."""
    coeffs, gains = stationary_start(rho, n)
    src = np.moveaxis(x, axis, 0)
    out = np.empty_like(src)
    for i in range(src.shape[0]):
        m = min(i, n)
        acc = scale * gains[m] * src[i]
        for j in range(m):
            acc = acc + coeffs[m][j] * out[i - 1 - j]
        out[i] = acc
    return np.moveaxis(out, 0, axis)


def sample(
    rho: Sequence[float], order: Sequence[int], sigma: float, noise: np.ndarray
) -> np.ndarray:
    """x = σ L_0 ⋯ L_{N-1} ξ, each L_k the stationary-start recursion of axis k (§1.2–1.3)."""
    x = np.asarray(noise, dtype=float)
    for axis in reversed(range(x.ndim)):
        x = _recurse_axis(x, axis, rho[axis], order[axis], sigma if axis == 0 else 1.0)
    return x


def stream_frame(
    rho: Sequence[float],
    order: Sequence[int],
    sigma: float,
    history: list[np.ndarray],
    t: int,
    noise: np.ndarray,
) -> np.ndarray:
    """Frame t of a stream (axis 0 = time) from its noise and the previous frames (most recent
    first): a spatial field, then the time recursion at position t (§1.4)."""
    spatial = sample(rho[1:], order[1:], 1.0, noise)
    n = order[0]
    coeffs, gains = stationary_start(rho[0], n)
    m = min(t, n)
    frame = sigma * gains[m] * spatial
    for j in range(m):
        frame = frame + coeffs[m][j] * history[j]
    return frame


def product_field(
    rho: Sequence[float], order: Sequence[int], sigma: float, noises: Sequence[np.ndarray]
) -> np.ndarray:
    """x_ī = σ Π_k s^{(k)}_{i_k}, s^{(k)} the unit-variance 1-D field of axis k (§1.4)."""
    out = np.full((), sigma)
    for r, n, xi in zip(rho, order, noises):
        out = np.multiply.outer(out, sample([r], [n], 1.0, xi))
    return out


def _directions(ndim: int, points: int) -> tuple[np.ndarray, np.ndarray]:
    """Midpoint-rule directions on the positive orthant of the unit sphere, with weights."""
    if ndim == 2:
        phi = (np.arange(points) + 0.5) * (np.pi / 2) / points
        return np.stack([np.cos(phi), np.sin(phi)], axis=1), np.ones(points)
    if ndim == 3:  # uniform in z = cos θ and φ gives the uniform surface measure
        z = (np.arange(points) + 0.5) / points
        phi = (np.arange(points) + 0.5) * (np.pi / 2) / points
        zz, pp = np.meshgrid(z, phi, indexing="ij")
        s = np.sqrt(1 - zz**2)
        u = np.stack([zz.ravel(), (s * np.cos(pp)).ravel(), (s * np.sin(pp)).ravel()], axis=1)
        return u, np.ones(len(u))
    raise NotImplementedError("the reference anisotropy covers 2 and 3 axes")


def anisotropy(rho: Sequence[float], order: Sequence[int], points: int = 600) -> float:
    """A_τ (§1.5): τ(u) by Gauss–Laguerre in t on R itself, sphere mean by midpoints."""
    u, w = _directions(len(rho), points)
    nodes, weights = np.polynomial.laguerre.laggauss(64)
    lam = np.abs(u) @ np.log(1 / np.asarray(rho))
    t = nodes[None, :] / lam[:, None]  # ∫ f(t) dt = (1/λ) ∫ e^{-s} [f(s/λ) e^{s}] ds
    lags = np.abs(u)[:, None, :] * t[:, :, None]
    integrand = correlation(rho, order, 1.0, lags) * np.exp(nodes)[None, :]
    tau = (integrand @ weights) / lam
    mean = np.average(tau, weights=w)
    return float(np.sqrt(np.average((tau - mean) ** 2, weights=w)) / mean)
