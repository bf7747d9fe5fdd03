"""The best linear (non-causal) estimator's error on a finite grid (SPEC §2.4)."""

from __future__ import annotations

import numpy as np

from .. import _core
from .._validation import ShapeLike, check_memory, grid_shape, positive_float
from ..field.model import ARFieldModel
from .base import in_image_units, row_model, unit_scale


def wiener_bound(model: ARFieldModel, noise_var: float, shape: ShapeLike) -> float:
    """Mean error variance of the best linear estimator of x from z = x + θ on a grid of
    `shape` (H, W): the floor no filter can beat.

    Exact: Cov(x) = σ² R_y ⊗ R_x, so with R = UΛUᵀ per axis the posterior covariance is
    diagonal in U_y ⊗ U_x with entries f_ab = σ²λ_aμ_b σ_θ² / (σ²λ_aμ_b + σ_θ²); the bound is
    their mean. O(H³ + W³) (faer eigendecompositions).
    """
    h, w = _checked_grid(shape)
    unit, ratio, sigma = _unit_parameters(model, noise_var)
    return _core.wiener_bound(unit._core, ratio, h, w) * sigma * sigma


def wiener_error_map(model: ARFieldModel, noise_var: float, shape: ShapeLike) -> np.ndarray:
    """Per-pixel error variance of the best linear estimator: (U_y∘U_y) F (U_x∘U_x)ᵀ."""
    h, w = _checked_grid(shape)
    check_memory((h, w), np.dtype(np.float64), copies=2)
    unit, ratio, sigma = _unit_parameters(model, noise_var)
    return in_image_units(_core.wiener_map(unit._core, ratio, h, w), sigma)


def _unit_parameters(model: object, noise_var: object) -> tuple[ARFieldModel, float, float]:
    """The checked model with σ_x = 1, σ_θ²/σ_x² and σ_x (:func:`unit_scale`: the products
    σ_x² σ_θ² of the bound would overflow at σ_x ~ 1e100)."""
    model = row_model(model)
    unit, ratio = unit_scale(model, positive_float(noise_var, "noise_var"))
    return unit, ratio, model.sigma


def _checked_grid(shape: ShapeLike) -> tuple[int, int]:
    """(H, W), refusing grids whose two axis eigenbases (H × H and W × W, with the
    eigensolver's workspace) exceed the machine's memory (MemoryError)."""
    h, w = grid_shape(shape, 2)
    check_memory((h * h + w * w,), np.dtype(np.float64), copies=3)
    return h, w
