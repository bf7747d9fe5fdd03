"""A space–time model and the noise level from a noisy stack alone (method page
*Sequence filter*, §2.5.1): what ``denoise(temporal=True)`` filters with."""

from __future__ import annotations

import numpy as np

from ..field.model import ARFieldModel
from ..identification.from_noisy import model_from_noisy

#: ρ_t is kept within [MIN_RHO_T, MAX_RHO_T] (a model needs 0 < ρ_t < 1).
MIN_RHO_T, MAX_RHO_T = 1e-3, 0.999


def sequence_model_from_noisy(frames: np.ndarray) -> tuple[ARFieldModel, float, float]:
    """(model (t, y, x), mean, σ_θ²) of a noisy (F, H, W) stack: the spatial model, mean
    and noise variance by :func:`model_from_noisy` over the frames; ρ_t (multiplicity 1)
    from the lag-1 covariance between successive frames, which white noise leaves
    untouched: ρ_t = c_t(1) / σ². ValueError with fewer than 2 frames."""
    if frames.shape[0] < 2:
        raise ValueError("a temporal model needs at least 2 frames")
    spatial, mean, noise_var = model_from_noisy(frames)
    centred = frames - mean
    lagged = np.nanmean(centred[1:] * centred[:-1])
    rho_t = float(np.clip(lagged / spatial.sigma**2, MIN_RHO_T, MAX_RHO_T))
    model = ARFieldModel((rho_t, *spatial.rho), (1, *spatial.order), spatial.sigma)
    return model, mean, noise_var
