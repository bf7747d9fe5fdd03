"""The spatial model of the fast filter's prediction error (method page *Sequence filter*,
§2.5.3): a separable AR model whose multiplicities and (ρ_y, ρ_x, σ) minimise the steady
MSE of the whole fast recursion, evaluated per spatial frequency, and for n_t = 2 the gain c
of the previous estimate's correction x̂_{t−1|t} = x̂_{t−1} + c·û_t."""

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


def loop_mse(model: ARFieldModel, ratio: float, gain: np.ndarray, smoothing: float = 0.0) -> float:
    """Mean steady error variance of the fast recursion with per-frequency update gains
    `gain` (same grid as :func:`field_spectrum`) and correction gain c = `smoothing`, in
    units of σ_x². Per frequency, with u_t = Σ_j α_j ε_{t−j} + w_t the prediction error
    (ε_{t−1} = e_{t−1}, ε_{t−2} = f_{t−1}), the errors e_t = (1 − g) u_t − g θ_t of x̂_t and
    f_t = e_{t−1} − c g (u_t + θ_t) of x̂_{t−1|t} follow a 2-state linear recursion; its
    steady covariance solves a 3 × 3 Lyapunov system (n_t ≤ 2: beyond, the loop is unstable
    for some gains). An unstable loop gives inf."""
    alpha = np.zeros(2)
    alpha[: model.order[0]] = _ar_coefficients(model.rho[0], model.order[0])
    drive = _beta_tilde_sq(model.rho[0], model.order[0])
    g = gain.ravel()
    cg = smoothing * g
    a = np.empty((g.size, 2, 2))
    a[:, 0, 0], a[:, 0, 1] = (1 - g) * alpha[0], (1 - g) * alpha[1]
    a[:, 1, 0], a[:, 1, 1] = 1 - cg * alpha[0], -cg * alpha[1]
    trace, det = a[:, 0, 0] + a[:, 1, 1], a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    if np.any(np.abs(det) >= 1) or np.any(np.abs(trace) >= 1 + det):  # (Jury's test)
        return float("inf")
    w = drive * field_spectrum(model).ravel()
    q0 = (1 - g) ** 2 * w + g**2 * ratio
    a00, a01, a10, a11 = a[:, 0, 0], a[:, 0, 1], a[:, 1, 0], a[:, 1, 1]
    if model.order[0] == 1:  # (f never feeds back: e is an AR(1) sequence)
        return float(np.mean(q0 / (1 - a00**2)))
    q = np.stack([q0, -(1 - g) * cg * w + g * cg * ratio, cg**2 * (w + ratio)], axis=1)
    m = np.stack(
        [
            np.stack([a00**2, 2 * a00 * a01, a01**2], axis=1),
            np.stack([a00 * a10, a00 * a11 + a01 * a10, a01 * a11], axis=1),
            np.stack([a10**2, 2 * a10 * a11, a11**2], axis=1),
        ],
        axis=1,
    )
    system = np.eye(3) - m
    # P_00 by Cramer's rule (a batched 3 × 3 solve costs ~10× more)
    first = system.copy()
    first[:, :, 0] = q
    return float(np.mean(_det3(first) / _det3(system)))


def _det3(m: np.ndarray) -> np.ndarray:
    """Determinants of a stack of 3 × 3 matrices (explicitly: LAPACK's batched one is slower)."""
    return (
        m[:, 0, 0] * (m[:, 1, 1] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 1])
        - m[:, 0, 1] * (m[:, 1, 0] * m[:, 2, 2] - m[:, 1, 2] * m[:, 2, 0])
        + m[:, 0, 2] * (m[:, 1, 0] * m[:, 2, 1] - m[:, 1, 1] * m[:, 2, 0])
    )


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


def error_model(model: ARFieldModel, ratio: float) -> tuple[ARFieldModel, float, float]:
    """The 2-axis model of the steady prediction error for a (t, y, x) `model` with σ = 1 at
    noise ratio σ_θ²/σ_x² = `ratio`, the correction gain c (0 for n_t = 1) and the design's
    predicted MSE (units of σ_x²).

    Per candidate multiplicities (1 or 2 per axis, and the field's own), a pattern search over
    (ρ_y, ρ_x, log σ²) from the field's spatial ρ (a gaining step doubles, up to its start;
    all halve when none gains, until they are below 1e-4); the candidate of least predicted
    MSE wins. For n_t = 2 the search also moves c (from 0.9): the gains g that suit the
    corrected prediction differ from those of c = 0."""
    candidates = {(a, b) for a in (1, 2) for b in (1, 2)} | {(model.order[1], model.order[2])}
    fits = [_fit(model, ratio, orders) for orders in sorted(candidates)]
    return min(fits, key=lambda fit: fit[2])


def _fit(
    model: ARFieldModel, ratio: float, orders: tuple[int, int]
) -> tuple[ARFieldModel, float, float]:
    corrected = model.order[0] >= 2
    params = np.array([model.rho[1], model.rho[2], 0.0, 0.9 if corrected else 0.0])

    def mse(p):
        return loop_mse(model, ratio, _gain(p, orders, ratio), p[3])

    best = mse(params)
    initial = np.array([0.05, 0.05, 0.5, 0.1])
    steps = initial.copy()
    moving = 4 if corrected else 3
    while steps[:moving].max() > 1e-4:
        moved = False
        for i in range(moving):
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
    return fitted, float(params[3]), best
