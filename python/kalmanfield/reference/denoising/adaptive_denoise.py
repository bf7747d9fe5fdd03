"""NumPy twin of the Rust ``adaptive_denoise`` kernel (the adaptive mode of ``denoise``):
x̂ = μ + σ ξ̂ with the box moments of ``local_moments`` and the weighted quasi-optimal row
filter of ``row_filters`` (Toeplitz modes)."""

from __future__ import annotations

import numpy as np

from ..rowfilter.row_filters import model_ar_order, scalar_filter_plan, scalar_row_filter
from .local_moments import local_moments

#: Floor of σ² in units of σ_θ², and the largest sample of the nominal variance's median
#: (the Rust constants).
SIGNAL_FLOOR = 0.01
NOMINAL_SAMPLE = 1 << 14


def adaptive_denoise(z, noise_var, rho, order, radius, smooth=True, row_models="nominal"):
    """Denoise one image (H, W) of noise variance `noise_var`; the detail field ξ has the
    row model (rho, order) with unit variance; window 2·radius + 1. NaN pixels are missing
    (weight 0, σ kept); a box without an observed pixel is widened (radius 2r + 1, …) until
    it holds one. `row_models`: the filter's (``weighted_systems``)."""
    z = np.asarray(z, dtype=np.float64)
    observed = ~np.isnan(z)
    if not observed.any():
        raise ValueError("a frame has no observed pixel: every pixel is NaN")
    mu, var = local_moments(z, radius)
    wide = radius
    while np.isnan(mu).any():  # boxes without an observed pixel: widened until they hold one
        wide = 2 * wide + 1
        hole = np.isnan(mu)
        wide_mu, wide_var = local_moments(z, wide)
        mu[hole], var[hole] = wide_mu[hole], wide_var[hole]
    signal = np.maximum(var - noise_var, SIGNAL_FLOOR * noise_var)
    weights = np.where(observed, signal / noise_var, 0.0)
    residual = np.where(observed, (np.where(observed, z, 0.0) - mu) / np.sqrt(signal), 0.0)
    nominal = 1.0 / _sample_median(weights.ravel())
    # not the filter's default (as the Rust kernel: every row is weighted)
    m = model_ar_order(order[1])
    plan = scalar_filter_plan(
        rho, order, 1.0, nominal, z.shape[1], z.shape[0], ar_order=m, modes="toeplitz"
    )
    detail = scalar_row_filter(
        residual,
        rho,
        order,
        1.0,
        nominal,
        smooth=smooth,
        ar_order=m,
        plan=plan,
        weights=weights,
        row_models=row_models,
    )
    return mu + np.sqrt(signal) * detail


def _sample_median(weights: np.ndarray) -> float:
    """The upper median of the observed (> 0) weights of the regular sample (stride
    ⌈len / NOMINAL_SAMPLE⌉), or of all observed weights if the sample holds none."""
    sample = weights[:: -(-weights.size // NOMINAL_SAMPLE)]
    sample = np.sort(sample[sample > 0] if (sample > 0).any() else weights[weights > 0])
    return float(sample[sample.size // 2])
