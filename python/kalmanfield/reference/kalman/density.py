"""The log-density of a whole measurement sequence under a linear-Gaussian model, from the
dense joint covariance of the stacked measurements (the exact value the summed innovation
log-likelihoods of the Kalman filter must equal; small cases only: O((N m)³))."""

from __future__ import annotations

import numpy as np

from .recursion import LN_2PI


def sequence_log_density(f, q, h, r, mean, cov, z):
    """ln N(z_1..z_N) with Cov(x_i, x_j) = F^(i−j) C_j (i ≥ j), C_k = F C_(k−1) Fᵀ + Q,
    C_0 = P0 one step before the first frame; rows of NaN in `z` are left out."""
    z = np.asarray(z, dtype=float)
    frames, m = z.shape
    means, covs = [], []
    for _ in range(frames):
        mean, cov = f @ mean, f @ cov @ f.T + q
        means.append(mean)
        covs.append(cov)
    sigma = np.zeros((frames * m, frames * m))
    for i in range(frames):
        for j in range(i + 1):
            block = h @ np.linalg.matrix_power(f, i - j) @ covs[j] @ h.T + (i == j) * r
            sigma[i * m : (i + 1) * m, j * m : (j + 1) * m] = block
            sigma[j * m : (j + 1) * m, i * m : (i + 1) * m] = block.T
    residual = (z - np.array([h @ x for x in means])).ravel()
    kept = ~np.isnan(residual)
    residual, sigma = residual[kept], sigma[np.ix_(kept, kept)]
    _, log_det = np.linalg.slogdet(sigma)
    quad = residual @ np.linalg.solve(sigma, residual)
    return -0.5 * (quad + log_det + len(residual) * LN_2PI)
