"""Effective memory: the weights w_j = h^T A^j k of the steady estimate, A = (I - k h^T)F."""

from __future__ import annotations

import numpy as np


def effective_memory(
    alpha: float, beta: float, tau: float = 1.0, level: float = 0.01, lags: int = 10_000
) -> int:
    """Number of lags j ≥ 0 with |w_j| > level (computed over `lags` lags)."""
    k = np.array([alpha, beta / tau])
    f = np.array([[1.0, tau], [0.0, 1.0]])
    a = (np.eye(2) - np.outer(k, [1.0, 0.0])) @ f
    weights, state = [], k
    for _ in range(lags):
        weights.append(state[0])
        state = a @ state
    return int((np.abs(weights) > level).sum())
