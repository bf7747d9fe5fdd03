"""The motion models as (F, Q, H, R) (twin of ``rust/src/kalman/motion.rs``): per axis
blocks, state axis after axis (position, velocity[, acceleration]), H picks the positions,
R = measurement_std² I."""

from __future__ import annotations

import numpy as np


def _per_axis(f_axis, q_axis, ndim, measurement_std):
    if ndim < 1:
        raise ValueError("ndim must be at least 1")
    if not measurement_std > 0:
        raise ValueError("measurement_std must be positive")
    d = len(f_axis)
    f = np.kron(np.eye(ndim), np.asarray(f_axis, float))
    q = np.kron(np.eye(ndim), np.asarray(q_axis, float))
    h = np.zeros((ndim, d * ndim))
    h[np.arange(ndim), np.arange(ndim) * d] = 1.0
    return f, q, h, np.eye(ndim) * measurement_std**2


def constant_velocity(dt, q, ndim, measurement_std=1.0):
    """F = [[1, T], [0, 1]], Q = q [[T³/3, T²/2], [T²/2, T]] (continuous white acceleration)."""
    f = [[1.0, dt], [0.0, 1.0]]
    qm = [[q * dt**3 / 3.0, q * dt**2 / 2.0], [q * dt**2 / 2.0, q * dt]]
    return _per_axis(f, qm, ndim, measurement_std)


def constant_acceleration(dt, q, ndim, measurement_std=1.0):
    """F = [[1, T, T²/2], [0, 1, T], [0, 0, 1]], Q = q [[T⁵/20, T⁴/8, T³/6], [T⁴/8, T³/3,
    T²/2], [T³/6, T²/2, T]] (continuous white jerk)."""
    f = [[1.0, dt, dt**2 / 2.0], [0.0, 1.0, dt], [0.0, 0.0, 1.0]]
    qm = q * np.array(
        [
            [dt**5 / 20.0, dt**4 / 8.0, dt**3 / 6.0],
            [dt**4 / 8.0, dt**3 / 3.0, dt**2 / 2.0],
            [dt**3 / 6.0, dt**2 / 2.0, dt],
        ]
    )
    return _per_axis(f, qm, ndim, measurement_std)


def singer(dt, rho, sigma_a, ndim, measurement_std=1.0):
    """F = [[1, T, T²/2], [0, 1, T], [0, 0, ρ]], Q = diag(0, 0, σ_a²(1 − ρ²))."""
    f = [[1.0, dt, dt**2 / 2.0], [0.0, 1.0, dt], [0.0, 0.0, rho]]
    return _per_axis(f, np.diag([0.0, 0.0, sigma_a**2 * (1.0 - rho**2)]), ndim, measurement_std)


def markov_velocity(dt, rho, sigma, ndim, measurement_std=1.0):
    """F = [[1, T], [0, ρ]], Q = diag(0, σ²(1 − ρ²))."""
    f = [[1.0, dt], [0.0, rho]]
    return _per_axis(f, np.diag([0.0, sigma**2 * (1.0 - rho**2)]), ndim, measurement_std)
