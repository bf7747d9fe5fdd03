"""One Kalman step in plain NumPy: predict, and the Joseph-form update (twin of
``rust/src/kalman/recursion.rs``)."""

from __future__ import annotations

import math

import numpy as np

LN_2PI = math.log(2.0 * math.pi)


def _symmetrised(a: np.ndarray) -> np.ndarray:
    return (a + np.swapaxes(a, -1, -2)) * 0.5


def check_covariance(a: np.ndarray, name: str, definite: bool = False) -> np.ndarray:
    """`a` symmetrised; ValueError unless finite, square, symmetric to 1e-10 of max|a| and
    positive semi-definite (positive definite if `definite`) to 1e-10 of its spectrum."""
    a = np.asarray(a, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"{name} must be square, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise ValueError(f"{name} must hold finite numbers")
    scale = np.abs(a).max(initial=0.0)
    if np.abs(a - a.T).max(initial=0.0) > 1e-10 * scale:
        raise ValueError(f"{name} must be symmetric")
    sym = _symmetrised(a)
    eigenvalues = np.linalg.eigvalsh(sym)
    floor = -1e-10 * np.abs(eigenvalues).max(initial=0.0)
    if definite and eigenvalues.min() <= 0.0:
        raise ValueError(f"{name} must be positive definite")
    if eigenvalues.min() < floor:
        raise ValueError(f"{name} must be positive semi-definite")
    return sym


def predict(f, q, mean, cov):
    """x⁻ = F x, P⁻ = F P Fᵀ + Q (symmetrised); `mean` (..., n), `cov` (..., n, n)."""
    return mean @ f.T, _symmetrised(f @ cov @ f.T + q)


def gain(h, r, predicted_cov):
    """(K, S⁻¹, ln det S, Joseph-form posterior covariance) for P⁻ (..., n, n)."""
    ph = predicted_cov @ h.T
    s = _symmetrised(h @ ph + r)
    chol = np.linalg.cholesky(s)
    log_det = 2.0 * np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(-1)
    precision = _symmetrised(np.linalg.inv(s))
    k = ph @ precision
    i_kh = np.eye(h.shape[1]) - k @ h
    posterior = _symmetrised(
        i_kh @ predicted_cov @ np.swapaxes(i_kh, -1, -2) + k @ r @ np.swapaxes(k, -1, -2)
    )
    return k, precision, log_det, posterior


def update(h, r, mean, cov, z):
    """(posterior mean, posterior cov, innovation, log-likelihood) of the predicted N(mean,
    cov) and measurement z; loglik = −½(νᵀS⁻¹ν + ln det S + m ln 2π)."""
    k, precision, log_det, posterior = gain(h, r, cov)
    nu = z - mean @ h.T
    quad = np.einsum("...i,...ij,...j->...", nu, precision, nu)
    loglik = -0.5 * (quad + log_det + h.shape[0] * LN_2PI)
    return mean + np.einsum("...ij,...j->...i", k, nu), posterior, nu, loglik


def filter_sequence(f, q, h, r, mean, cov, zs):
    """Predict-then-update over the rows of `zs` (a NaN row: predict only); returns the
    posterior means (N, n), covariances (N, n, n) and per-frame log-likelihoods (N,)."""
    means, covs, logliks = [], [], []
    for z in np.asarray(zs, dtype=float):
        mean, cov = predict(f, q, mean, cov)
        loglik = 0.0
        if np.isfinite(z).all():
            mean, cov, _, loglik = update(h, r, mean, cov, z)
        means.append(mean)
        covs.append(cov)
        logliks.append(loglik)
    return np.array(means), np.array(covs), np.array(logliks)
