"""``denoise(temporal=True)``: a stack filtered in space and time by the sequence filter
(method page *Sequence filter*)."""

from __future__ import annotations

import numpy as np

from ..field.model import ARFieldModel
from ..sequence.from_noisy import sequence_model_from_noisy
from ..sequence.sequence_filter import SequenceFilter, sequence_model


def denoise_sequence(
    z: np.ndarray,
    noise_var: float | None,
    model: ARFieldModel | None,
    mean: float | None,
    threads: int | None,
) -> np.ndarray:
    """The (F, H, W) stack `z` filtered by :class:`SequenceFilter` (method "auto"), with the
    model, mean and noise level fitted to `z` where not given."""
    if z.ndim != 3:
        raise ValueError(f"temporal=True needs an (F, H, W) stack, got {z.ndim} axes")
    if model is None:
        model, fitted_mean, fitted_var = sequence_model_from_noisy(z)
        mean = fitted_mean if mean is None else mean
        noise_var = fitted_var if noise_var is None else noise_var
    else:
        sequence_model(model)
        if noise_var is None:
            _, _, noise_var = sequence_model_from_noisy(z)
        mean = float(np.nanmean(z)) if mean is None else mean
    if not noise_var > 0:
        raise ValueError("the noise variance was estimated as 0: give noise_var or sigma")
    shape = (z.shape[1], z.shape[2])
    return SequenceFilter(model, noise_var, shape, mean=mean, threads=threads).filter(z)
