"""NumPy twin of the Rust ``noise_level`` kernel: Donoho's Haar-MAD estimate of the white
noise variance used by ``denoise``."""

from __future__ import annotations

import numpy as np

#: Φ⁻¹(3/4), the standard normal's upper quartile (the median of |N(0, 1)|).
NORMAL_QUARTILE = 0.6744897501960817


def haar_noise_var(z: np.ndarray) -> float:
    """σ̂² = (median|d| / Φ⁻¹(3/4))² over the finest diagonal Haar details
    d = (z₀₀ − z₀₁ − z₁₀ + z₁₁)/2 of the disjoint 2×2 blocks of an image or stack (…, H, W);
    blocks with a NaN or infinite pixel are left out."""
    z = np.asarray(z, dtype=np.float64)
    h, w = z.shape[-2] // 2 * 2, z.shape[-1] // 2 * 2
    z = z[..., :h, :w]
    detail = (z[..., 0::2, 0::2] - z[..., 0::2, 1::2] - z[..., 1::2, 0::2] + z[..., 1::2, 1::2]) / 2
    detail = detail[np.isfinite(detail)]
    if detail.size == 0:
        raise ValueError(
            "no 2×2 block without a NaN (missing) or infinite pixel: cannot estimate the noise"
        )
    sigma = float(np.median(np.abs(detail))) / NORMAL_QUARTILE
    # σ·σ as the kernel: NumPy's scalar `** 2` is not always the rounded product (1 ulp off
    # for σ² = 5.581006062510948, a hypothesis case)
    return sigma * sigma
