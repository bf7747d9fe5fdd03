"""Plots of the trajectory filters (matplotlib, the ``demo`` extra, imported when called)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from .._validation import nonnegative_int
from ._inputs import series_array, times_array
from .change_detector import ChangePoints
from .fuzzy_filter import FuzzyFilter
from .kalman_filter import KalmanFilterCV
from .motion_filter import MotionFilter

#: the settings of [K95]'s Fig. 1 and Fig. 2 (a, b), as keywords of the filters
SOURCE_FIGURES: dict[int, tuple[dict[str, float], dict[str, float]]] = {
    1: (
        dict(P=1.0, P_vel=1.0, Q=1.0, Q_vel=1.0, R=1.0),
        dict(P=1.0, P_vel=1.0, Q=1.0, Q_vel=1.0, R=2.0),
    ),
    2: (
        dict(P=1.0, P_vel=1.0, Q=0.1, Q_vel=0.1, R=1.0),
        dict(P=2.0, P_vel=2.0, Q=0.1, Q_vel=0.1, R=1.0),
    ),
}


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:  # pragma: no cover - depends on the environment
        raise ImportError("plots need matplotlib: pip install 'kalmanfield[demo]'") from err
    return plt


def plot_gains(
    filters: Sequence[MotionFilter], n: int = 15, ax: Any = None, label: str = ""
) -> Any:
    """Plot the gains α_n (circles) and β_n (squares) of filters against n.

    Fuzzy filters are drawn solid, Kalman filters dashed (the style of [K95]'s figures).

    Parameters
    ----------
    filters : sequence of FuzzyFilter or KalmanFilterCV
        The filters whose gains :meth:`FuzzyFilter.gains` are drawn.
    n : int, optional
        Number of samples (default 15).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default the current axes).
    label : str, optional
        Appended to each line's legend label.

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from kalmanfield import FuzzyFilter, KalmanFilterCV
    >>> from kalmanfield.trajectory import plot_gains
    >>> fig, ax = plt.subplots()
    >>> filters = [FuzzyFilter(1.0, 1.0, 1.0), KalmanFilterCV(1.0, 1.0, 1.0)]
    >>> len(plot_gains(filters, n=10, ax=ax).lines)
    4
    >>> plt.close(fig)
    """
    plt = _pyplot()
    ax = ax if ax is not None else plt.gca()
    steps = np.arange(n)
    for f in filters:
        g = f.gains(n)
        style = "-" if isinstance(f, FuzzyFilter) else "--"
        name = "fuzzy" if isinstance(f, FuzzyFilter) else "Kalman"
        ax.plot(steps, g[:, 0], style, marker="o", ms=3, color="C0", label=f"α {name}{label}")
        ax.plot(steps, g[:, 1], style, marker="s", ms=3, color="C1", label=f"β {name}{label}")
    ax.set_xlabel("n")
    ax.set_ylabel("gain")
    return ax


def plot_gain_comparison(figure: int = 1, n: int = 15) -> Any:
    """Plot [K95]'s Fig. 1 or Fig. 2: the gains of the fuzzy and Kalman filters compared.

    Settings a and b (:data:`SOURCE_FIGURES`) side by side; fuzzy solid, Kalman dashed.

    Parameters
    ----------
    figure : {1, 2}, optional
        The source's figure: 1 (R changes) or 2 (P, P' change); default 1.
    n : int, optional
        Number of samples (default 15).

    Returns
    -------
    matplotlib.figure.Figure
        The figure, two axes.

    Raises
    ------
    ValueError
        A figure other than 1 or 2.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from kalmanfield.trajectory import plot_gain_comparison
    >>> fig = plot_gain_comparison(2)
    >>> len(fig.axes)
    2
    >>> plt.close(fig)
    """
    if isinstance(figure, (bool, np.bool_)) or figure not in SOURCE_FIGURES:
        raise ValueError(f"figure must be 1 or 2, got {figure!r}")
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.4), sharey=True)
    for ax, tag, settings in zip(axes, "ab", SOURCE_FIGURES[figure]):
        plot_gains([FuzzyFilter(**settings), KalmanFilterCV(**settings)], n=n, ax=ax)
        ax.set_title(f"Fig. {figure}{tag}: " + ", ".join(f"{k}={v:g}" for k, v in settings.items()))
        ax.title.set_fontsize(8)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    return fig


def plot_change_points(
    z: npt.ArrayLike,
    found: ChangePoints,
    times: npt.ArrayLike | None = None,
    series: int = 0,
    ax: Any = None,
) -> Any:
    """Plot one series' samples, its restarted estimates and its alarms (vertical lines).

    Parameters
    ----------
    z : array-like
        The samples given to :meth:`ChangeDetector.run`, (n,) or (series, n).
    found : ChangePoints
        What :meth:`ChangeDetector.run` returned for them.
    times : array-like, optional
        The samples' times, (n,) or shaped like `z` (default 0, 1, …).
    series : int, optional
        Which series of a batch to draw (default 0).
    ax : matplotlib.axes.Axes, optional
        Where to draw (default the current axes).

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn on.

    Raises
    ------
    ValueError
        `z`, `times` or `series` that do not match the samples `found` was computed on.
    TypeError
        `found` not a ChangePoints; non-numeric `z` or `times`.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import numpy as np
    >>> from kalmanfield import ChangeDetector, FuzzyFilter
    >>> from kalmanfield.trajectory import plot_change_points
    >>> z = np.r_[np.zeros(30), np.full(30, 10.0)]
    >>> found = ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2)).run(z)
    >>> fig, ax = plt.subplots()
    >>> ax = plot_change_points(z, found, ax=ax)
    >>> plt.close(fig)
    """
    if not isinstance(found, ChangePoints):
        kind = type(found).__name__
        raise TypeError(f"found must be what ChangeDetector.run returned, got {kind}")
    samples = series_array(z)
    if samples.shape != found.alarm.shape:
        raise ValueError(
            f"z has the shape {samples.shape}, found was computed on {found.alarm.shape}"
        )
    series = nonnegative_int(series, "series")
    rows = samples.shape[0] if samples.ndim == 2 else 1
    if series >= rows:
        raise ValueError(f"series must be below {rows}, the number of series, got {series}")
    pick = (lambda a: a) if samples.ndim == 1 else (lambda a: a[series])
    zz = pick(samples)
    given = times_array(times, samples.shape)
    if given is None:
        t = np.arange(zz.size, dtype=float)
    else:
        t = given if given.ndim == 1 else given[series]
    plt = _pyplot()
    ax = ax if ax is not None else plt.gca()
    ax.plot(t, zz, ".", color="0.5", ms=3, label="samples")
    ax.plot(t, pick(found.position), "-", color="C0", label="estimate")
    for k in np.flatnonzero(pick(found.alarm)):
        ax.axvline(t[k], color="C3", lw=0.8)
    ax.set_xlabel("t")
    return ax
