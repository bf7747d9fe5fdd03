"""The bank of Kalman filters over a batch (twin of ``rust/src/filterbank``).

A model is a tuple (F, Q, H, R, x0, P0); (x0, P0) is the prior one step before the first
frame, so every frame predicts first. Measurements are (B, N, m); a row of NaN is a missed
frame (predict only). Without missed frames one covariance recursion per model serves every
trajectory; with them each trajectory carries its own covariances (B, n, n).
"""

from __future__ import annotations

import numpy as np

from ..kalman import LN_2PI, gain, predict

UNDECIDED = -1


def wald_thresholds(alpha: float, beta: float) -> tuple[float, float]:
    """(lower, upper) = (ln(β/(1 − α)), ln((1 − β)/α)) for L_1 − L_0."""
    return float(np.log(beta / (1.0 - alpha))), float(np.log((1.0 - beta) / alpha))


def _model_log_likelihoods(model, z, observed):
    """Per-frame log-likelihood increments (B, N) of one model."""
    f, q, h, r, x0, p0 = model
    b, frames, m = z.shape
    mean = np.broadcast_to(x0, (b, len(x0))).copy()
    shared = observed.all()
    cov = p0 if shared else np.broadcast_to(p0, (b, *p0.shape)).copy()
    out = np.zeros((b, frames))
    for t in range(frames):
        mean, cov = predict(f, q, mean, cov)
        k, precision, log_det, posterior = gain(h, r, cov)
        nu = z[:, t] - mean @ h.T
        seen = observed[:, t]
        if shared:
            step = nu @ k.T
            quad = np.einsum("bi,ij,bj->b", nu, precision, nu)
        else:
            nu = np.where(seen[:, None], nu, 0.0)
            step = np.einsum("bia,ba->bi", k, nu)
            quad = np.einsum("bi,bij,bj->b", nu, precision, nu)
            posterior = np.where(seen[:, None, None], posterior, cov)
        mean = mean + step
        cov = posterior
        out[:, t] = np.where(seen, -0.5 * (quad + log_det + m * LN_2PI), 0.0)
    return out


def _decisions(cumulative, log_priors, thresholds):
    """Per-frame decisions (B, N) from accumulated log-likelihoods (B, N, K)."""
    if thresholds is None:
        return np.argmax(cumulative + log_priors, axis=2)
    lower, upper = thresholds
    ratio = cumulative[:, :, 1] - cumulative[:, :, 0]
    decisions = np.full(ratio.shape, UNDECIDED)
    current = np.full(ratio.shape[0], UNDECIDED)
    for t in range(ratio.shape[1]):
        open_ = current == UNDECIDED
        current = np.where(open_ & (ratio[:, t] >= upper), 1, current)
        current = np.where(open_ & (ratio[:, t] <= lower), 0, current)
        decisions[:, t] = current
    return decisions


def bank_run(measurements, models, priors=None, alpha=None, beta=None):
    """(decisions (B, N), accumulated log-likelihoods (B, N, K)) of the bank on a batch."""
    z = np.asarray(measurements, dtype=float)
    observed = ~np.isnan(z).all(axis=2)
    k = len(models)
    priors = np.full(k, 1.0 / k) if priors is None else np.asarray(priors, float)
    increments = np.stack([_model_log_likelihoods(mod, z, observed) for mod in models], axis=2)
    cumulative = np.cumsum(increments, axis=1)
    thresholds = None if alpha is None else wald_thresholds(alpha, beta)
    with np.errstate(divide="ignore"):
        log_priors = np.log(priors)
    return _decisions(cumulative, log_priors, thresholds), cumulative


def posterior(log_likelihoods, priors):
    """Posterior type probabilities from accumulated log-likelihoods (..., K)."""
    with np.errstate(divide="ignore"):
        w = log_likelihoods + np.log(priors)
    w = np.exp(w - w.max(axis=-1, keepdims=True))
    return w / w.sum(axis=-1, keepdims=True)
