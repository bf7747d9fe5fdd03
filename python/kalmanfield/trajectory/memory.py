"""The effective memory of a filter with steady gains [K95, comparison]."""

from __future__ import annotations

import numpy.typing as npt

from .. import _core
from .._validation import positive_float, real_array


def effective_memory(gains: npt.ArrayLike, level: float = 0.01, tau: float = 1.0) -> int:
    """The number of past samples whose weight in the steady estimate exceeds `level`.

    The steady estimate is x̂_n = Σ_j w_j z_{n-j} with w_j = h^T A^j k, A = (I - k h^T)F,
    k = (α, β/τ), h = (1, 0), F = [[1, τ], [0, 1]]; the count includes the current sample.

    Parameters
    ----------
    gains : array-like
        The output of ``.gains(n)``, an (n, 2) array whose last row (α, β) is taken as the
        steady gains; or one pair (α, β); or one number α (β = 0).
    level : float, optional
        The weight ω (default 0.01, the source's).
    tau : float, optional
        The time step τ (default 1).

    Returns
    -------
    int
        The number of lags j ≥ 0 whose weight w_j exceeds `level` in absolute value.

    Raises
    ------
    ValueError
        Gains outside 0 ≤ α ≤ 1, β ≥ 0, weights that do not decay, a non-positive level or τ,
        the (n, 2, 2) gain matrices of the Kalman variant with velocity measurements.

    Notes
    -----
    At P = Q = R = 1, P' = Q' = 0 this gives 3 for :class:`FuzzyFilter` and 5 for
    :class:`KalmanFilterCV` ([K95]: "3–4" and 5). The weights are §4.5 of the method page
    *Fuzzy filter* (:doc:`/methods/fuzzy_filter`).

    Examples
    --------
    >>> from kalmanfield import FuzzyFilter, KalmanFilterCV, effective_memory
    >>> effective_memory(FuzzyFilter(1.0, 1.0, 1.0).gains(30))
    3
    >>> effective_memory(KalmanFilterCV(1.0, 1.0, 1.0).gains(30))
    5
    """
    g = real_array(gains, "gains")
    if g.ndim == 0:
        alpha, beta = float(g), 0.0
    elif g.shape == (2,):
        alpha, beta = float(g[0]), float(g[1])
    elif g.ndim == 2 and g.shape[1] == 2 and g.shape[0] > 0:
        alpha, beta = float(g[-1, 0]), float(g[-1, 1])
    else:
        raise ValueError(f"gains must be a number, a pair (α, β) or an (n, 2) array, got {g.shape}")
    return int(
        _core.effective_memory(
            alpha, beta, positive_float(tau, "tau"), positive_float(level, "level")
        )
    )
