"""General (not necessarily separable) 2-D autoregression by the generalised Yule–Walker
system (method page *Identification*, §1.6; [P 2.24–2.27])."""

from __future__ import annotations

import numbers
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .._validation import observed, power_of_two_exponent, real_array
from .sample_correlation import sample_correlation


@dataclass(frozen=True)
class YuleWalkerModel:
    """A general 2-D quarter-plane autoregression Σ_{i≤n_y, j≤n_x} α_ij x_{k−i, l−j} = β ξ_kl.

    ξ is white N(0, 1) and α_00 = 1.

    Parameters
    ----------
    alpha : numpy.ndarray
        The (n_y + 1, n_x + 1) template, α_00 = 1, in the sign convention of
        :meth:`ARFieldModel.coefficients` (for a separable field the two agree).
    beta : float
        Innovation standard deviation, β² = Σ Σ α_ij α_pq C(p − i, q − j) [P 2.27].
    variance : float
        The variance σ_x², the sample variance of the valid pixels.
    mean : float
        Mean of the valid pixels.

    See Also
    --------
    yule_walker : Makes it from an image.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel(0.7, [1, 1]).sample((256, 256), seed=1)
    >>> fit = kf.yule_walker(x, (1, 1))
    >>> fit.predict(x).shape  # NaN on the first row and column
    (256, 256)
    """

    alpha: np.ndarray
    beta: float
    variance: float
    mean: float

    def predict(self, image: npt.ArrayLike) -> np.ndarray:
        """One-step quarter-plane prediction x̂_kl = mean − Σ_{(i,j)≠0} α_ij (x − mean)_{k−i,l−j}.

        Parameters
        ----------
        image : array_like
            A 2-D image; NaN pixels are missing.

        Returns
        -------
        numpy.ndarray
            The prediction, of the image's shape; NaN where the template leaves the image
            or touches a missing pixel.

        Raises
        ------
        ValueError
            An image that is not 2-D, infinite pixels, a prediction that overflows float64.
        """
        x = real_array(image, "image")
        if x.ndim != 2:
            raise ValueError(f"image must be 2-D, got {x.ndim}-D")
        if np.isinf(x).any():
            raise ValueError("image holds infinite pixels (NaN marks a missing one)")
        with np.errstate(over="ignore", invalid="ignore"):
            x = x - self.mean
            out = self._predict_centred(x)
        if np.isinf(x).any() or np.isinf(out).any() or np.isnan(out[self._defined(x)]).any():
            raise ValueError("the prediction overflows float64: rescale the image")
        return out

    def _defined(self, x: np.ndarray) -> np.ndarray:
        """Where a prediction of the centred image x is defined: the template inside the
        image and on no NaN pixel (:meth:`_predict_centred` of x · 0 is 0 there)."""
        return ~np.isnan(self._predict_centred(x * 0.0))

    def _predict_centred(self, x: np.ndarray) -> np.ndarray:
        n_y, n_x = self.alpha.shape[0] - 1, self.alpha.shape[1] - 1
        out = np.full(x.shape, np.nan)
        if x.shape[0] <= n_y or x.shape[1] <= n_x:
            return out
        core = np.zeros((x.shape[0] - n_y, x.shape[1] - n_x))
        for i in range(n_y + 1):
            for j in range(n_x + 1):
                if i or j:
                    core -= self.alpha[i, j] * x[n_y - i : x.shape[0] - i, n_x - j : x.shape[1] - j]
        out[n_y:, n_x:] = core + self.mean
        return out


def yule_walker(
    image: npt.ArrayLike,
    order: tuple[int, int] | Sequence[int] = (1, 1),
    mask: npt.ArrayLike | None = None,
) -> YuleWalkerModel:
    """Fit a general 2-D autoregression of template (n_y + 1) × (n_x + 1) to an image.

    Parameters
    ----------
    image : array_like
        A 2-D image; NaN and masked pixels are missing.
    order : tuple of int, default (1, 1)
        (n_y, n_x), each ≥ 0, not both 0.
    mask : array_like of bool, optional
        True = leave the pixel out.

    Returns
    -------
    YuleWalkerModel
        The template α, β, the variance and the mean.

    Raises
    ------
    ValueError
        An image that is not 2-D, too small for the order, with lags that have no pair of
        observed pixels, or whose Yule–Walker system is singular.
    TypeError
        An order that is not a pair of integers.

    See Also
    --------
    identify : The better tool for separable models (this system is ill-conditioned for
        high orders on smooth images).

    Notes
    -----
    Solves Σ_{(i,j)} α_ij C(i − s, j − t) = 0 for every (s, t) ≠ (0, 0) of the template,
    then β² = Σ Σ α_ij α_pq C(p − i, q − j), with C the unbiased sample autocovariance
    (§1.6 of :doc:`/methods/identification`).

    References
    ----------
    .. [1] O. V. Popov, dissertation, Ulyanovsk, 2000, eqs. 2.24–2.27 ([P] in
       :doc:`/references`).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel(0.7, [1, 1]).sample((256, 256), seed=1)
    >>> kf.yule_walker(x, (1, 1)).alpha.round(1)
    array([[ 1. , -0.7],
           [-0.7,  0.5]])
    """
    n_y, n_x = _template_order(order)
    values, valid = observed(image, mask, "image")
    if values.ndim != 2:
        raise ValueError(f"image must be 2-D, got {values.ndim}-D")
    if values.shape[0] <= 2 * n_y or values.shape[1] <= 2 * n_x:
        raise ValueError(f"an image of shape {values.shape} is too small for order {(n_y, n_x)}")
    correlation = sample_correlation(values, (n_y, n_x))
    if not np.isfinite(correlation).all():
        raise ValueError(
            f"some lags of the order-{(n_y, n_x)} template have no pair of observed pixels"
        )
    kept = values[valid]
    # by a power of two (exact): the squares stay inside float64 (1e-170 data underflowed)
    with np.errstate(over="ignore", invalid="ignore"):
        mean = float(kept.mean())
        exponent = power_of_two_exponent(kept - mean)
    shift = 0 if exponent is None else exponent
    with np.errstate(over="ignore", under="ignore"):
        variance = float(np.ldexp(np.var(np.ldexp(kept, -shift)), 2 * shift))
    if not np.isfinite(variance):
        raise ValueError("the data's variance overflows float64: rescale them")
    if exponent is not None and not variance > 0:
        raise ValueError("the data's variance underflows float64: rescale them")
    return yule_walker_from_covariance(variance * correlation, mean)


def yule_walker_from_covariance(covariance: np.ndarray, mean: float = 0.0) -> YuleWalkerModel:
    """The Yule–Walker model from a covariance array C of shape (2n_y+1, 2n_x+1), centred at
    lag (0, 0) (the layout of :func:`sample_correlation`)."""
    c = np.asarray(covariance, dtype=np.float64)
    n_y, n_x = (c.shape[0] - 1) // 2, (c.shape[1] - 1) // 2

    def cov(dy: int, dx: int) -> float:
        return c[n_y + dy, n_x + dx]

    points = [(i, j) for i in range(n_y + 1) for j in range(n_x + 1)][1:]
    system = np.array([[cov(i - s, j - t) for (i, j) in points] for (s, t) in points])
    rhs = -np.array([cov(-s, -t) for (s, t) in points])
    try:
        solution = np.linalg.solve(system, rhs) if points else np.zeros(0)
    except np.linalg.LinAlgError:
        raise ValueError("the Yule–Walker system is singular (a degenerate image?)") from None
    alpha = np.zeros((n_y + 1, n_x + 1))
    alpha[0, 0] = 1.0
    for (i, j), a in zip(points, solution):
        alpha[i, j] = a
    everything = [(0, 0), *points]
    beta_sq = sum(
        alpha[i, j] * alpha[p, q] * cov(p - i, q - j)
        for (i, j) in everything
        for (p, q) in everything
    )
    return YuleWalkerModel(alpha, float(np.sqrt(max(beta_sq, 0.0))), float(cov(0, 0)), mean)


def _template_order(order: tuple[int, int] | Sequence[int]) -> tuple[int, int]:
    if not isinstance(order, Iterable) or isinstance(order, str):
        raise TypeError(f"order must be a pair (n_y, n_x) of integers, got {order!r}")
    items = tuple(order)
    if len(items) != 2:
        raise ValueError(f"order must be a pair (n_y, n_x), got {order!r}")
    for n in items:
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, numbers.Integral):
            raise TypeError(f"order must hold integers, got {n!r}")
        if n < 0:
            raise ValueError(f"order entries must be ≥ 0, got {n}")
    if items == (0, 0):
        raise ValueError("order (0, 0) has no coefficient to fit")
    return int(items[0]), int(items[1])
