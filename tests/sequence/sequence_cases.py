"""Shared helpers of the sequence filter tests: the dense (brute-force) Gaussian
conditioning over whole vectorised sequences."""

from __future__ import annotations

import numpy as np

import kalmanfield as kf


def sequence_covariance(model: kf.ARFieldModel, frames: int, shape: tuple[int, int]):
    """Cov of the vectorised (frames · H · W) sequence, σ² R_t(t − u) R_y(i − k) R_x(j − l)."""
    h, w = shape
    t, i, j = np.meshgrid(np.arange(frames), np.arange(h), np.arange(w), indexing="ij")
    points = np.stack([t.ravel(), i.ravel(), j.ravel()], axis=1)
    lags = points[:, None, :] - points[None, :, :]
    return model.correlation(lags)


def brute_force(model, noise_var, z, observed_until, target):
    """E[x_target | z_0..observed_until] and its per-pixel variance by dense conditioning
    (NaN pixels are not observed)."""
    frames, h, w = z.shape
    size = h * w
    cov = sequence_covariance(model, frames, (h, w))
    seen = np.zeros(frames * size, dtype=bool)
    seen[: (observed_until + 1) * size] = True
    seen &= ~np.isnan(z.ravel())
    rows = slice(target * size, (target + 1) * size)
    c_xz = cov[rows][:, seen]
    c_zz = cov[np.ix_(seen, seen)] + noise_var * np.eye(seen.sum())
    mean = c_xz @ np.linalg.solve(c_zz, z.ravel()[seen])
    var = np.diag(cov[rows, rows]) - np.einsum("ij,ji->i", c_xz, np.linalg.solve(c_zz, c_xz.T))
    return mean.reshape(h, w), var.reshape(h, w)


def noisy_sequence(model, noise_var, frames, shape, seed):
    rng = np.random.default_rng(seed)
    x = model.sample((frames, *shape), seed=int(rng.integers(2**32)))
    return x, x + np.sqrt(noise_var) * rng.normal(size=x.shape)
