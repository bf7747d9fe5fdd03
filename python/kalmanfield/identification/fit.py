"""Identification of separable multiple-root AR field models from data (method page
*Identification*, §1.6)."""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from math import comb
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from .._channels import check_channel_axis
from .._validation import observed, positive_int, power_of_two_exponent, thread_count
from ..field.model import ARFieldModel

#: Highest multiplicity `identify` considers.
MAX_IDENTIFIED_ORDER = 8
#: ρ is searched in [RHO_MIN, RHO_MAX].
RHO_MIN, RHO_MAX = 1e-4, 1.0 - 1e-6
_CORRELATION_LAGS = 16
_WHITENESS_LAGS = 10


@dataclass(frozen=True)
class WhitenessTest:
    """Box–Pierce whiteness test of the whitened residual along one axis.

    Q = Σ_{h=1..L} N_h r_h², with r_h the residual's correlation at lag h and N_h its number
    of pairs, is χ²_L under whiteness.

    Parameters
    ----------
    statistic : float
        Q.
    dof : int
        L, the degrees of freedom (the lags tested).
    pvalue : float
        P(χ²_L ≥ Q).
    residual_correlation : numpy.ndarray
        The residual's correlations r_1..r_L.
    whitened_with : tuple of float
        The ρ of each modelled axis the residual was whitened with (of the fitted orders):
        each refitted on the data whitened along the other axes, the efficient estimate
        under the model (the reported ρ summarises the correlation along each axis alone;
        for a true separable field the two agree within the fits' errors).

    See Also
    --------
    identify : Fills one per modelled axis, in ``IdentifiedModel.fits``.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel(0.8, [1, 1]).sample((256, 256), seed=2)
    >>> test = kf.identify(x).fits[0].whiteness
    >>> test.dof, bool(test.pvalue > 0.001)
    (10, True)
    """

    statistic: float
    dof: int
    pvalue: float
    residual_correlation: np.ndarray  # r_1..r_L
    whitened_with: tuple[float, ...] = ()


@dataclass(frozen=True)
class AxisFit:
    """The fit of one data axis: every candidate multiplicity and the chosen one.

    Parameters
    ----------
    axis : int
        The data axis.
    order : int
        The chosen multiplicity n.
    rho : float
        The chosen ρ.
    candidate_orders : numpy.ndarray
        The multiplicities tried, 1..max_order.
    candidate_rho : numpy.ndarray
        The best ρ of each candidate.
    innovation_variance : numpy.ndarray
        The σ̂²_e of each candidate (the pooled one-step prediction error variance).
    criterion : numpy.ndarray
        N ln σ̂²_e of each candidate (the least wins).
    pairs : int
        N, the number of prediction errors pooled.
    lags : numpy.ndarray
        Lags 0..16 (fewer on short axes) of the correlations below.
    sample_correlation : numpy.ndarray
        The data's correlation at `lags`.
    fitted_correlation : numpy.ndarray
        The fitted model's correlation at `lags`.
    whiteness : WhitenessTest
        The residual's whiteness test.

    See Also
    --------
    identify : Fills one per modelled axis, in ``IdentifiedModel.fits``.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((256, 256), seed=1)
    >>> rows = kf.identify(x).fits[0]
    >>> rows.axis, rows.order, rows.candidate_orders.tolist()
    (0, 2, [1, 2, 3, 4])
    """

    axis: int
    order: int
    rho: float
    candidate_orders: np.ndarray
    candidate_rho: np.ndarray
    innovation_variance: np.ndarray
    criterion: np.ndarray
    pairs: int
    lags: np.ndarray
    sample_correlation: np.ndarray
    fitted_correlation: np.ndarray
    whiteness: WhitenessTest


@dataclass(frozen=True)
class IdentifiedModel:
    """Result of :func:`identify`: the fitted model and the diagnostics of every axis.

    Parameters
    ----------
    model : ARFieldModel
        The fitted model, one axis per modelled data axis.
    mean : float
        Mean of the valid pixels.
    variance : float
        The field variance σ², the sample variance corrected for the bias of a correlated sample.
    sample_variance : float
        The plain sample variance s² of the valid pixels.
    axes : tuple of int
        The data axes that carry the model.
    fits : tuple of AxisFit
        The fit of each modelled axis.

    See Also
    --------
    identify : Makes it.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((256, 256), seed=1)
    >>> fit = kf.identify(x)
    >>> fit.order, fit.fits[1].order
    ((2, 1), 1)
    """

    model: ARFieldModel
    mean: float
    variance: float
    sample_variance: float
    axes: tuple[int, ...]
    fits: tuple[AxisFit, ...]

    @property
    def rho(self) -> tuple[float, ...]:
        """The ρ of each modelled axis (a tuple)."""
        return self.model.rho

    @property
    def order(self) -> tuple[int, ...]:
        """The multiplicity n of each modelled axis (a tuple)."""
        return self.model.order

    def summary(self, level: float = 0.01) -> str:
        """A text table of the fit, with the verdict in words.

        Parameters
        ----------
        level : float, default 0.01
            The significance level of the whiteness tests.

        Returns
        -------
        str
            One line for the model, one per axis (every candidate n's criterion and the
            test), and a last line saying whether the model is rejected at `level` on any
            axis (its residual not white: a model of higher order, or another kind of
            model, is needed there).
        """
        lines = [f"{self.model!r}, mean {self.mean:.6g}"]
        for fit in self.fits:
            crit = ", ".join(
                f"n={n}: {c - fit.criterion.min():.1f}"
                for n, c in zip(fit.candidate_orders, fit.criterion)
            )
            w = fit.whiteness
            lines.append(
                f"axis {fit.axis}: n={fit.order}, rho={fit.rho:.5f}; Δcriterion {crit}; "
                f"residual Q={w.statistic:.1f} (dof {w.dof}, p={w.pvalue:.3g})"
            )
        rejected = [f.axis for f in self.fits if f.whiteness.pvalue < level]
        if rejected:
            lines.append(
                f"The model is rejected at the {level:g} level: the residual is not white "
                f"along axis {', '.join(map(str, rejected))} (try a higher max_order, or the "
                "data are not a separable AR field there)."
            )
        else:
            lines.append(
                f"The model is not rejected at the {level:g} level: the residual is white "
                "along every modelled axis."
            )
        return "\n".join(lines)

    def plot(self, axes=None):
        """Plot the sample against the fitted correlation of every axis (matplotlib).

        Parameters
        ----------
        axes : array of matplotlib.axes.Axes, optional
            One Axes per modelled axis (default: a new figure).

        Returns
        -------
        numpy.ndarray
            The Axes drawn on.
        """
        import matplotlib.pyplot as plt

        if axes is None:
            n = len(self.fits)
            _, axes = plt.subplots(
                1, n, figsize=(4.5 * n, 3.5), squeeze=False, constrained_layout=True
            )
        axes = np.ravel(axes)
        for ax, fit in zip(axes, self.fits):
            ax.plot(fit.lags, fit.sample_correlation, "o", label="sample")
            ax.plot(fit.lags, fit.fitted_correlation, "-", label=f"n={fit.order}, ρ={fit.rho:.3f}")
            ax.set_xlabel(f"lag along axis {fit.axis}")
            ax.set_ylabel("correlation")
            ax.legend()
        return axes


def identify(
    data: npt.ArrayLike,
    max_order: int = 4,
    axes: Sequence[int] | None = None,
    *,
    mask: npt.ArrayLike | None = None,
    channel_axis: int | None = None,
    threads: int | None = None,
) -> IdentifiedModel:
    """Identify the separable multiple-root model of an image or a stack.

    Per modelled axis: the multiplicity n and ρ by likelihood, then σ² and the mean; with
    diagnostics (every candidate's criterion, sample against fitted correlation, a
    whiteness test of the residual).

    Parameters
    ----------
    data : array_like
        1-D, 2-D or 3-D data (a stack has its time axis first); uint8, uint16, int or float.
        NaN, infinite and ``numpy.ma``-masked pixels are missing: every difference or lag
        touching one is skipped.
    max_order : int, default 4
        Highest multiplicity tried (1..8).
    axes : sequence of int, optional
        The data axes that carry the model (default all, in order); the other axes hold
        independent replicates (colour channels, independent images).
    mask : array_like of bool, optional
        True = leave the pixel out (the ``numpy.ma`` convention).
    channel_axis : int, optional
        The axis of colour channels (scikit-image's convention): the channels are
        replicates of one model, like the axes left out of `axes` (which must not name it).
    threads : int, optional
        Number of threads (None: all cores).

    Returns
    -------
    IdentifiedModel
        The model (``.model``) and the diagnostics of every axis (``.fits``).

    Raises
    ------
    ValueError
        Data that are not 1-D to 3-D, constant (overall or along an axis), without a valid
        pixel, too short along an axis for `max_order`, or whose variance is beyond
        float64; bad `axes` or `mask`.
    TypeError
        Data of bool, complex or non-numeric dtype; axes that are not integers.

    Warns
    -----
    RuntimeWarning
        ρ sits at the edge of (0, 1) along an axis: the data look like a trend or white
        noise there.

    Notes
    -----
    Every line of a separable field along axis k is a 1-D AR(n_k) sequence with root
    1/ρ_k. For each candidate n, ρ minimises the pooled one-step prediction error of
    (1 − ρ z⁻¹)ⁿ over all lines; the n of least N ln σ̂²_e wins. σ² is the sample variance
    divided by 1 − R̄, R̄ the fitted correlation averaged over all pixel pairs: the exact
    correction of its bias when the correlation length is not small against the data. The
    method, and why it replaces the source's route, is §1.6 of
    :doc:`/methods/identification`.

    References
    ----------
    .. [1] O. V. Popov, dissertation, Ulyanovsk, 2000, section 2.4 ([P] in :doc:`/references`).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> x = kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((256, 256), seed=1)
    >>> fit = kf.identify(x)
    >>> fit.order
    (2, 1)
    >>> [round(r, 2) for r in fit.rho]
    [0.9, 0.71]
    """
    values, valid = observed(data)
    if mask is not None:
        values, valid = observed(np.ma.MaskedArray(values, mask=~valid), mask)
    if not 1 <= values.ndim <= 3:
        raise ValueError(f"data must be 1-D, 2-D or 3-D, got {values.ndim}-D")
    max_order = positive_int(max_order, "max_order")
    if max_order > MAX_IDENTIFIED_ORDER:
        raise ValueError(f"max_order must be at most {MAX_IDENTIFIED_ORDER}, got {max_order}")
    model_axes = _model_axes(axes, values.ndim, check_channel_axis(channel_axis, values.ndim))
    threads = thread_count(threads)
    if not valid.any():
        raise ValueError("data have no valid (finite, unmasked) pixel")
    complete = bool(valid.all())
    mean = float(values.mean() if complete else values[valid].mean())
    centred, exponent = _unit_scaled(values - mean, valid, complete)
    unit_variance = np.mean(centred**2 if complete else centred[valid] ** 2)
    with np.errstate(over="ignore", under="ignore"):
        sample_variance = float(np.ldexp(unit_variance, 2 * exponent))
    if not (np.isfinite(sample_variance) and sample_variance > 0):
        raise ValueError(
            f"the data's variance ({unit_variance:.3g}·2^{2 * exponent}) is beyond float64: "
            "rescale them"
        )
    choices = [_fit_axis(centred, k, max_order, threads, exponent) for k in model_axes]
    rho = tuple(c[0] for c in choices)
    order = tuple(c[1] for c in choices)
    variance = sample_variance / (1 - _mean_pair_correlation(values.shape, model_axes, rho, order))
    model = ARFieldModel(rho, order, sigma=float(np.sqrt(variance)))
    tested = _tested_rho(centred, model_axes, rho, order)
    residual = _residual(centred, model_axes, tested, order)
    fits = tuple(
        _diagnose(centred, residual, k, c, threads, tested) for k, c in zip(model_axes, choices)
    )
    return IdentifiedModel(model, mean, variance, sample_variance, model_axes, fits)


def _tested_rho(centred, axes, rho, order) -> tuple[float, ...]:
    """The ρ the whiteness test whitens with: each axis' ρ fitted again (same order) on the
    data whitened along the other axes, so that its lines are independent and ρ̂ is as
    precise as the whole grid allows. The reported ρ is the per-axis fit to the correlation
    along the axis (what :meth:`IdentifiedModel.plot` shows, and the right summary of a real
    image, which no separable model fits exactly); for a true separable field both estimate
    the same ρ, but the per-axis one is noisier (a (1,1) ρ = 0.9 on 128²: 3× the efficient
    SD), and whitened with it the residual failed the test at 1 % in 15 % of true grids."""
    if len(axes) < 2:
        return tuple(rho)
    out: list[float] = []
    for k, n in zip(axes, order):
        others = [i for i, a in enumerate(axes) if a != k]
        partial = _residual(
            centred, [axes[i] for i in others], [rho[i] for i in others], [order[i] for i in others]
        )
        gram, pairs = _core.difference_gram(partial, k, n, None)
        out.append(_best_rho(gram / max(pairs, 1), n)[0] if pairs > 4 * (n + 1) else rho[len(out)])
    return tuple(out)


def _mean_pair_correlation(shape, axes, rho, order) -> float:
    """Mean of R over all pairs of grid pixels, Π_k (1/n_k²) Σ_h (n_k - |h|) R_k(h), with 0
    across replicates: E[sample variance] = σ² (1 - this) for the fitted model."""
    out = 1.0
    for k, length in enumerate(shape):
        if k in axes:
            r, n = rho[axes.index(k)], order[axes.index(k)]
            h = np.arange(-(length - 1), length)
            out *= float(np.sum((length - np.abs(h)) * _axis_correlation(r, n, h))) / length**2
        else:
            out /= length
    return min(out, 0.999)


def _axis_correlation(rho: float, n: int, lags: np.ndarray) -> np.ndarray:
    return ARFieldModel(rho, n).correlation(lags.astype(np.float64))


def _model_axes(axes: Sequence[int] | None, ndim: int, channel: int | None) -> tuple[int, ...]:
    """The axes that carry the model: `axes` checked, default every axis but the channels'."""
    if axes is None:
        return tuple(a for a in range(ndim) if a != channel)
    items: tuple[Any, ...] = (axes,) if isinstance(axes, numbers.Integral) else tuple(axes)
    out: list[int] = []
    for a in items:
        if isinstance(a, (bool, np.bool_)) or not isinstance(a, numbers.Integral):
            raise TypeError(f"axes must hold integers, got {a!r}")
        if not -ndim <= int(a) < ndim:
            raise ValueError(f"axis {a} is out of range for {ndim}-D data")
        out.append(int(a) % ndim)
    if not out or len(set(out)) != len(out):
        raise ValueError(f"axes must be distinct and non-empty, got {items}")
    if channel in out:
        raise ValueError(f"axes name the channel axis {channel}: channels are replicates")
    return tuple(out)


def _unit_scaled(centred: np.ndarray, valid: np.ndarray, complete: bool) -> tuple[np.ndarray, int]:
    """(centred · 2^−e, e) by :func:`power_of_two_exponent` (1e-160 data had underflowed to
    a wrong ρ, 1e154 ones overflowed)."""
    exponent = power_of_two_exponent(centred if complete else centred[valid])
    if exponent is None:
        raise ValueError("data are constant over their valid pixels: there is no model to fit")
    return np.ldexp(centred, -exponent), exponent


def _fit_axis(
    centred: np.ndarray, axis: int, max_order: int, threads: int | None, exponent: int = 0
):
    """Per candidate n: (ρ̂, σ̂_e²); returns the chosen (ρ, n, σ_e²) and the whole table.
    `centred` holds the data times 2^−exponent (the innovations are given in data units)."""
    if centred.shape[axis] <= max_order + 1:
        raise ValueError(
            f"axis {axis} has {centred.shape[axis]} pixels: too few for max_order {max_order} "
            f"(need at least {max_order + 2})"
        )
    gram, pairs = _core.difference_gram(centred, axis, max_order, threads)
    if pairs < 4 * (max_order + 1):
        raise ValueError(
            f"only {pairs} complete windows of {max_order + 1} valid pixels along axis {axis}: "
            f"too few to fit orders up to {max_order}"
        )
    table = [_best_rho(gram / pairs, n) for n in range(1, max_order + 1)]
    if not gram[1, 1] > 0:
        raise ValueError(f"data are constant along axis {axis}: there is no model to fit")
    rhos = np.array([t[0] for t in table])
    with np.errstate(over="ignore", under="ignore"):
        innovation = np.ldexp(np.array([t[1] for t in table]), 2 * exponent)
    criterion = pairs * np.log(innovation)
    best = int(np.argmin(criterion))
    if rhos[best] >= RHO_MAX * (1 - 1e-9) or rhos[best] <= RHO_MIN * (1 + 1e-9):
        warnings.warn(
            f"rho along axis {axis} sits at the bound of (0, 1) ({rhos[best]:.6g}): the data "
            "look non-stationary (a trend) or white along it",
            RuntimeWarning,
            stacklevel=3,
        )
    return rhos[best], best + 1, innovation[best], rhos, innovation, criterion, pairs


def _weights(rho: np.ndarray, n: int) -> np.ndarray:
    """w_m = C(n,m) ρ^m (1-ρ)^{n-m}: (1 - ρ z⁻¹)ⁿ = Σ_m w_m Dᵐ (D = 1 - z⁻¹)."""
    return np.array([comb(n, m) * rho**m * (1 - rho) ** (n - m) for m in range(n + 1)])


def _prediction_error(gram: np.ndarray, rho: np.ndarray, n: int) -> np.ndarray:
    w = _weights(rho, n)
    return np.einsum("ak,ab,bk->k", w, gram[: n + 1, : n + 1], w)


def minimise_over_rho(
    objective: Callable[[np.ndarray], np.ndarray], points: int, iterations: int
) -> float:
    """argmin over ρ ∈ [RHO_MIN, RHO_MAX] of a vectorised `objective` (array of ρ → array of
    values): a grid of `points` in -ln(1-ρ) (dense near 1), then grids of 17 points across
    the best bracket until it is as narrow as `iterations` golden-section steps would leave
    it (0.618^iterations of the first bracket; ~a quarter of the objective's calls)."""
    grid = 1 - np.exp(-np.linspace(-np.log1p(-RHO_MIN), -np.log1p(-RHO_MAX), points))
    lo, hi = _bracket(grid, objective(grid))
    narrowest = (hi - lo) * ((np.sqrt(5) - 1) / 2) ** iterations
    for _ in range(iterations):  # (a bound: float64 may stop the bracket from narrowing)
        if hi - lo <= narrowest:
            break
        grid = np.linspace(lo, hi, 17)
        lo, hi = _bracket(grid, objective(grid))
    return 0.5 * (lo + hi)


def _bracket(grid: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """The grid points either side of the smallest value."""
    k = int(np.argmin(values))
    return float(grid[max(k - 1, 0)]), float(grid[min(k + 1, grid.size - 1)])


def _best_rho(gram: np.ndarray, n: int) -> tuple[float, float]:
    """argmin over ρ of the mean squared prediction error (:func:`minimise_over_rho`)."""
    rho = minimise_over_rho(lambda r: _prediction_error(gram, r, n), 2001, 60)
    return float(rho), float(_prediction_error(gram, np.array([rho]), n)[0])


def _residual(centred, axes, rho, order) -> np.ndarray:
    residual = centred.copy()
    for k, r, n in zip(axes, rho, order):
        _core.whiten_axis_into(residual, k, r, n)
    return residual


def _diagnose(centred, residual, axis, choice, threads, tested) -> AxisFit:
    rho, n, _, rhos, innovation, criterion, pairs = choice
    length = centred.shape[axis]
    lags = np.arange(min(_CORRELATION_LAGS, length - 1) + 1)
    sums, counts = _core.lag_products(centred, axis, int(lags[-1]), threads)
    covariance = sums / np.maximum(counts, 1)
    sample = np.where(counts > 0, covariance / covariance[0], np.nan)
    return AxisFit(
        axis=axis,
        order=n,
        rho=rho,
        candidate_orders=np.arange(1, rhos.size + 1),
        candidate_rho=rhos,
        innovation_variance=innovation,
        criterion=criterion,
        pairs=int(pairs),
        lags=lags,
        sample_correlation=sample,
        fitted_correlation=_axis_correlation(rho, n, lags),
        whiteness=_whiteness(residual, axis, threads, tested),
    )


def _whiteness(
    residual: np.ndarray, axis: int, threads: int | None, tested: tuple[float, ...]
) -> WhitenessTest:
    max_lag = max(1, min(_WHITENESS_LAGS, residual.shape[axis] // 4))
    sums, counts = _core.lag_products(residual, axis, max_lag, threads)
    if counts[0] == 0 or not sums[0] > 0:
        nan = float("nan")
        return WhitenessTest(nan, max_lag, nan, np.full(max_lag, np.nan), tested)
    covariance = np.where(counts > 0, sums / np.maximum(counts, 1), 0.0)
    r = covariance[1:] / covariance[0]
    statistic = float(np.sum(counts[1:] * r**2))
    pvalue = _core.chi2_sf(statistic, float(max_lag))
    return WhitenessTest(statistic, max_lag, pvalue, r, tested)
