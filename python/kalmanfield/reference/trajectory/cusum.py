"""The CUSUM threshold: the mean run length of the one-sided CUSUM of N(0, 1) increments
from Page's integral equation L(x) = 1 + L(0)Φ(k - x) + ∫_0^h L(y)φ(y + k - x)dy by Nyström's
method (Gauss–Legendre), the two sides combined as 1/ARL = 2/L(0)."""

from __future__ import annotations

import math

import numpy as np

_SQRT2 = math.sqrt(2.0)


def _cdf(x):
    return 0.5 * np.vectorize(math.erfc)(-np.asarray(x, dtype=float) / _SQRT2)


def _pdf(x):
    return np.exp(-0.5 * np.asarray(x, dtype=float) ** 2) / math.sqrt(2 * math.pi)


def _nodes(h: float) -> int:
    return int(min(max(math.ceil(12 * h), 32), 480))


def _arl(h: float, k: float, n: int) -> float:
    if h <= 0:
        return 1.0 / (0.5 * math.erfc(k / _SQRT2))
    x, w = np.polynomial.legendre.leggauss(n)
    y, w = 0.5 * h * (x + 1), 0.5 * h * w
    points = np.concatenate([[0.0], y])
    a = np.eye(n + 1)
    a[:, 0] -= _cdf(k - points)
    a[:, 1:] -= w * _pdf(y[None, :] + k - points[:, None])
    return float(np.linalg.solve(a, np.ones(n + 1))[0])


def cusum_arl(h: float, k: float) -> float:
    """One-sided mean run length from a zero start."""
    return _arl(h, k, _nodes(h))


def cusum_threshold(confidence: float, k: float) -> float:
    """h with two-sided mean run length 1/(1 - confidence)."""
    target = math.log(2.0 / (1.0 - confidence))
    hi = 1.0
    while math.log(_arl(hi, k, _nodes(hi))) < target:
        hi *= 2
    n = _nodes(hi)
    lo = 0.0
    for _ in range(100):  # bisection
        mid = 0.5 * (lo + hi)
        if math.log(_arl(mid, k, n)) < target:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)
