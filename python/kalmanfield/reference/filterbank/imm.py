"""The IMM estimator over a batch (twin of ``rust/src/filterbank/imm.rs``), vectorised over
trajectories. Per frame: c̄ = μ M, ω_ij = M_ij μ_i / c̄_j, mixed moments per model, predict,
update, μ ∝ c̄ ∘ exp(ℓ), combined moments. A missed frame (NaN row): μ = c̄, states
predicted."""

from __future__ import annotations

import numpy as np

from ..kalman import LN_2PI, gain, predict


def imm_run(measurements, models, transition, mu):
    """(combined states (B, N, n), mode probabilities (B, N, K), log-likelihoods (B, N))."""
    z = np.asarray(measurements, dtype=float)
    b, frames, m = z.shape
    transition = np.asarray(transition, float)
    k, n = len(models), len(models[0][4])
    means = np.stack([np.broadcast_to(mod[4], (b, n)) for mod in models], axis=1)
    covs = np.stack([np.broadcast_to(mod[5], (b, n, n)) for mod in models], axis=1)
    mu = np.broadcast_to(np.asarray(mu, float), (b, k)).copy()
    states = np.zeros((b, frames, n))
    modes = np.zeros((b, frames, k))
    logliks = np.zeros((b, frames))
    for t in range(frames):
        cbar = mu @ transition
        with np.errstate(divide="ignore", invalid="ignore"):
            omega = transition[None] * mu[:, :, None] / cbar[:, None, :]
        omega = np.where(cbar[:, None, :] > 0, omega, mu[:, :, None])
        mixed = np.einsum("bij,bin->bjn", omega, means)
        d = means[:, :, None, :] - mixed[:, None, :, :]  # (b, i, j, n)
        spread = covs[:, :, None] + d[..., :, None] * d[..., None, :]
        mixed_cov = np.einsum("bij,bijnp->bjnp", omega, spread)
        seen = ~np.isnan(z[:, t]).all(axis=1)
        log_w = np.log(cbar)
        for j, (f, q, h, r, _, _) in enumerate(models):
            mean, cov = predict(f, q, mixed[:, j], mixed_cov[:, j])
            kg, precision, log_det, posterior = gain(h, r, cov)
            nu = np.where(seen[:, None], z[:, t] - mean @ h.T, 0.0)
            quad = np.einsum("bi,bij,bj->b", nu, precision, nu)
            means[:, j] = mean + np.einsum("bia,ba->bi", kg, nu)
            covs[:, j] = np.where(seen[:, None, None], posterior, cov)
            log_w[:, j] += -0.5 * (quad + log_det + m * LN_2PI)
        top = log_w.max(axis=1, keepdims=True)
        w = np.exp(log_w - top)
        total = top[:, 0] + np.log(w.sum(axis=1))
        mu = np.where(seen[:, None], w / w.sum(axis=1, keepdims=True), cbar)
        logliks[:, t] = np.where(seen, total, 0.0)
        states[:, t] = np.einsum("bj,bjn->bn", mu, means)
        modes[:, t] = mu
    return states, modes, logliks
