"""The spatial model of the fast filter's prediction error (method page *Sequence filter*,
§2.5.3): a separable AR model whose multiplicities and (ρ_y, ρ_x, σ) minimise the steady
MSE of the whole fast recursion, evaluated per spatial frequency."""

from __future__ import annotations

from math import comb

import numpy as np

from ..field.model import ARFieldModel

#: Spatial frequencies per axis of the design grid (midpoints over (0, π)).
FREQUENCIES = 64
#: Highest temporal multiplicity of the fast filter.
MAX_FAST_ORDER = 2


def axis_spectrum(rho: float, order: int, omega: np.ndarray) -> np.ndarray:
    """The spectral density of a unit-variance axis, β̃² / (1 − 2ρ cos ω + ρ²)^n (its mean
    over (0, π) is 1)."""
    return _beta_tilde_sq(rho, order) / (1 - 2 * rho * np.cos(omega) + rho**2) ** order


def _beta_tilde_sq(rho: float, order: int) -> float:
    return (1 - rho**2) ** (2 * order - 1) / sum(
        (comb(order - 1, k) * rho**k) ** 2 for k in range(order)
    )


def _ar_coefficients(rho: float, order: int) -> np.ndarray:
    return np.array([(-1) ** (j + 1) * comb(order, j) * rho**j for j in range(1, order + 1)])


def loop_mse(model: ARFieldModel, ratio: float, gain: np.ndarray) -> float:
    """Mean steady error variance of the fast recursion with per-frequency update gains
    `gain` (same grid as :func:`field_spectrum`), in units of σ_x²: per frequency the error
    e_t = (1 − g)(Σ_j α_j e_{t−j} + w_t) − g θ_t is an AR(n_t) sequence (n_t ≤ 2: beyond,
    the loop is unstable for some gains), of closed-form variance."""
    alpha = _ar_coefficients(model.rho[0], model.order[0])
    drive = _beta_tilde_sq(model.rho[0], model.order[0])
    g = gain.ravel()
    q = (1 - g) ** 2 * field_spectrum(model).ravel() * drive + g**2 * ratio
    a = (1 - g)[:, None] * alpha
    if alpha.size == 1:
        return float(np.mean(q / (1 - a[:, 0] ** 2)))
    a1, a2 = a[:, 0], a[:, 1]  # (n_t = 2: stable, (1 − g)(2ρ − ρ²) < 1)
    return float(np.mean(q * (1 - a2) / ((1 + a2) * ((1 - a2) ** 2 - a1**2))))


def field_spectrum(model: ARFieldModel) -> np.ndarray:
    """The spatial spectral density of a (t, y, x) model with σ = 1 on the design grid."""
    omega = (np.arange(FREQUENCIES) + 0.5) * np.pi / FREQUENCIES
    return np.outer(
        axis_spectrum(model.rho[1], model.order[1], omega),
        axis_spectrum(model.rho[2], model.order[2], omega),
    )


def _gain(params: np.ndarray, orders: tuple[int, int], ratio: float) -> np.ndarray:
    omega = (np.arange(FREQUENCIES) + 0.5) * np.pi / FREQUENCIES
    s = np.exp(params[2]) * np.outer(
        axis_spectrum(params[0], orders[0], omega), axis_spectrum(params[1], orders[1], omega)
    )
    return s / (s + ratio)


def error_model(model: ARFieldModel, ratio: float) -> tuple[ARFieldModel, float]:
    """The 2-axis model of the steady prediction error for a (t, y, x) `model` with σ = 1 at
    noise ratio σ_θ²/σ_x² = `ratio`, and the design's predicted MSE (units of σ_x²).

    Per candidate multiplicities (1 or 2 per axis, and the field's own), a pattern search over
    (ρ_y, ρ_x, log σ²) from the field's spatial ρ (a gaining step doubles, up to its start;
    all halve when none gains, until they are below 1e-4); the candidate of least predicted
    MSE wins."""
    candidates = {(a, b) for a in (1, 2) for b in (1, 2)} | {(model.order[1], model.order[2])}
    fits = [_fit(model, ratio, orders) for orders in sorted(candidates)]
    return min(fits, key=lambda fit: fit[1])


def _fit(model: ARFieldModel, ratio: float, orders: tuple[int, int]) -> tuple[ARFieldModel, float]:
    params = np.array([model.rho[1], model.rho[2], 0.0])

    def mse(p):
        return loop_mse(model, ratio, _gain(p, orders, ratio))

    best = mse(params)
    initial = np.array([0.05, 0.05, 0.5])
    steps = initial.copy()
    while steps.max() > 1e-4:
        moved = False
        for i in range(3):
            for sign in (1.0, -1.0):
                trial = params.copy()
                trial[i] += sign * steps[i]
                if i < 2 and not 1e-3 < trial[i] < 0.9999:
                    continue
                value = mse(trial)
                if value < best:
                    params, best, moved = trial, value, True
                    # a step that gains grows (up to its start): along a diagonal valley
                    # the fixed steps zigzag for tens of thousands of evaluations
                    steps[i] = min(2 * steps[i], initial[i])
        if not moved:
            steps /= 2
    fitted = ARFieldModel(
        [float(params[0]), float(params[1])], list(orders), float(np.exp(params[2] / 2))
    )
    return fitted, best
