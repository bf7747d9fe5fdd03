"""NumPy twin of the Rust ``adaptive_denoise`` kernel (the adaptive mode of ``denoise``):
x̂ = μ + σ ξ̂ with the box moments of ``local_moments`` and the weighted quasi-optimal row
filter of ``row_filters`` (Toeplitz modes)."""

from __future__ import annotations

import numpy as np

from .local_moments import local_moments
from .row_filters import scalar_filter_plan, scalar_row_filter

#: Floor of σ² in units of σ_θ², and the largest sample of the nominal variance's median
#: (the Rust constants).
SIGNAL_FLOOR = 0.01
NOMINAL_SAMPLE = 1 << 14


def adaptive_denoise(z, noise_var, rho, order, radius, smooth=True):
    """Denoise one image (H, W) of noise variance `noise_var`; the detail field ξ has the
    row model (rho, order) with unit variance; window 2·radius + 1."""
    z = np.asarray(z, dtype=np.float64)
    mu, var = local_moments(z, radius)
    signal = np.maximum(var - noise_var, SIGNAL_FLOOR * noise_var)
    weights = signal / noise_var
    residual = (z - mu) / np.sqrt(signal)
    stride = -(-weights.size // NOMINAL_SAMPLE)
    sample = np.sort(weights.ravel()[::stride])
    nominal = 1.0 / sample[sample.size // 2]
    plan = scalar_filter_plan(rho, order, 1.0, nominal, z.shape[1], z.shape[0], modes="toeplitz")
    detail = scalar_row_filter(
        residual, rho, order, 1.0, nominal, smooth=smooth, plan=plan, weights=weights
    )
    return mu + np.sqrt(weights * noise_var) * detail
