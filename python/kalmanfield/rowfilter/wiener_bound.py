"""The best linear (non-causal) estimator's error on a finite grid (method page *Row filters*,
§2.4)."""

from __future__ import annotations

import numpy as np

from .. import _core
from .._validation import ShapeLike, check_memory, grid_shape, positive_float
from ..field.model import ARFieldModel
from .base import in_image_units, row_model, unit_scale


def wiener_bound(model: ARFieldModel, noise_var: float, shape: ShapeLike) -> float:
    """Mean error variance of the best linear estimator of x from z = x + θ on a grid.

    The floor no filter can beat on that grid.

    Parameters
    ----------
    model : ARFieldModel
        2-axis field model of x, row multiplicity n_y ≤ 4.
    noise_var : float
        Variance σ_θ² of the white observation noise.
    shape : tuple of int
        Grid shape (H, W).

    Returns
    -------
    float
        The mean over the grid of the posterior error variance.

    Raises
    ------
    ValueError
        A model without two axes, a noise ratio outside float64's normal range.
    MemoryError
        The H × H and W × W eigenbases do not fit in memory.

    Notes
    -----
    Cov(x) = σ² R_y ⊗ R_x, so with R = U Λ Uᵀ per axis the posterior covariance is diagonal
    in U_y ⊗ U_x, with entries σ²λ_a μ_b σ_θ² / (σ²λ_a μ_b + σ_θ²): O(H³ + W³) (§2.4 of
    :doc:`/methods/row_filters`).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel([0.9, 0.9], [1, 1])
    >>> round(kf.wiener_bound(model, 1.0, (100, 100)), 4)
    0.1245
    """
    h, w = _checked_grid(shape)
    unit, ratio, sigma = _unit_parameters(model, noise_var)
    return _core.wiener_bound(unit._core, ratio, h, w) * sigma * sigma


def wiener_error_map(model: ARFieldModel, noise_var: float, shape: ShapeLike) -> np.ndarray:
    """Per-pixel error variance of the best linear estimator of x from z = x + θ.

    Parameters
    ----------
    model : ARFieldModel
        2-axis field model of x, row multiplicity n_y ≤ 4.
    noise_var : float
        Variance σ_θ² of the white observation noise.
    shape : tuple of int
        Grid shape (H, W).

    Returns
    -------
    numpy.ndarray
        The (H, W) map, (U_y∘U_y) F (U_x∘U_x)ᵀ in the notation of :func:`wiener_bound`;
        its mean is the bound.

    Raises
    ------
    ValueError
        A model without two axes, a noise ratio outside float64's normal range.
    MemoryError
        The map or the eigenbases do not fit in memory.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel([0.9, 0.9], [1, 1])
    >>> error = kf.wiener_error_map(model, 1.0, (100, 100))
    >>> bool(error[0, 0] > error[50, 50])  # the corners see fewer neighbours
    True
    """
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
