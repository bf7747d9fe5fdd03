"""Plots of the trajectory filters (matplotlib, the ``demo`` extra, imported when called)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

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
    """α_n (circles) and β_n (squares) against n; fuzzy filters solid, Kalman dashed (the
    style of [K95]'s figures). Returns the axes."""
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
    """[K95]'s Fig. 1 or Fig. 2: the gains of the fuzzy (solid) and Kalman (dashed) filters
    for settings a and b side by side. Returns the matplotlib Figure."""
    if figure not in SOURCE_FIGURES:
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
    """The samples, the restarted estimates and the alarms (vertical lines) of one series.
    Returns the axes."""
    plt = _pyplot()
    ax = ax if ax is not None else plt.gca()
    zz = np.atleast_2d(np.asarray(z, dtype=float))[series]
    pick = (lambda a: a) if found.alarm.ndim == 1 else (lambda a: a[series])
    t = np.arange(zz.size) if times is None else np.asarray(times, dtype=float)
    ax.plot(t, zz, ".", color="0.5", ms=3, label="samples")
    ax.plot(t, pick(found.position), "-", color="C0", label="estimate")
    for k in np.flatnonzero(pick(found.alarm)):
        ax.axvline(t[k], color="C3", lw=0.8)
    ax.set_xlabel("t")
    return ax
