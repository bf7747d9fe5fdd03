"""The source's detection experiment [K93, end of §3] (method page *Extended objects*, §3.5):
probability P_o of correct detection of a moving rhombus against random spots and foreign
objects, per SNR and clutter probability P_f."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd
import tqdm

from .._validation import SeedLike, positive_int, resolve_seed
from ..extended import detect_moving_objects, simulate_scene
from .type_confusion import _wilson

__all__ = ["SOURCE_P_O", "k93", "k93_correct", "plot_k93"]

#: the source's table: (SNR, P_f) → P_o
SOURCE_P_O = {(3.0, 0.3): 0.80, (3.0, 0.1): 0.90, (5.0, 0.3): 0.92, (5.0, 0.1): 0.98}


def k93_correct(
    objects: list, truth: pd.DataFrame, *, sigma_position: float = 1.0, sigma_velocity: float = 10.0
) -> bool:
    """Judge one run of the source's experiment by the 3σ rule.

    Correct when the best-ranked object is detected in the last frame, its centre there lies
    within 3 σ_position of the true centre on each axis, and its velocity within 3 σ_velocity
    of the true velocity on each axis.

    Parameters
    ----------
    objects : list of DetectedObject
        The detector's answer, best first.
    truth : pandas.DataFrame
        :attr:`Scene.truth` of the single target.
    sigma_position : float, default 1.0
        The std σ of a fragment centroid (pixels): the detector's ``position_std``.
    sigma_velocity : float, default 10.0
        The std σ of the velocity estimate (pixels per time unit): 1 pixel per frame at τ = 0.1.

    Returns
    -------
    bool
        Whether the run is correct.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> from kalmanfield.experiments import k93_correct
    >>> s = kf.simulate_scene((64, 64), 10, snr=5.0, p_false=0.1, dt=0.1, seed=2)
    >>> k93_correct(kf.detect_moving_objects(s.frames, noise_std=1.0, dt=0.1), s.truth)
    True
    """
    if not objects:
        return False
    last = int(truth["frame"].max())
    track = objects[0].track
    row = track[track["frame"] == last]
    if row.empty:
        return False
    got = row.iloc[0]
    true = truth[truth["frame"] == last].iloc[0]
    return bool(
        abs(got.x - true.x) <= 3 * sigma_position
        and abs(got.y - true.y) <= 3 * sigma_position
        and abs(got.vx - true.vx) <= 3 * sigma_velocity
        and abs(got.vy - true.vy) <= 3 * sigma_velocity
    )


def k93(
    snr: Sequence[float] = (3, 5),
    p_false: Sequence[float] = (0.3, 0.1),
    runs: int = 500,
    seed: SeedLike = 0,
    progress: bool = True,
    *,
    background: Any = None,
    n_frames: int = 10,
    **detector: Any,
) -> pd.DataFrame:
    """The source's experiment: P_o per SNR and P_f, with 95 % Wilson intervals.

    Each run simulates the source's scene (:func:`kalmanfield.simulate_scene` defaults: a
    10-px rhombus in 64 × 64 frames, τ = 0.1, the motion model (3.7), `spots` = 3 clutter
    spots in a frame with probability P_f, one still and one slower moving foreign rhombus,
    white noise σ = 1), runs :func:`kalmanfield.detect_moving_objects` (σ given, β = 0.99,
    N + 1 = 5) and judges it by :func:`k93_correct`.

    Parameters
    ----------
    snr : sequence of float, default (3, 5)
        Target amplitude over noise std.
    p_false : sequence of float, default (0.3, 0.1)
        Probability of clutter in a frame.
    runs : int, default 500
        Scenes per cell.
    seed : int, numpy.random.Generator or None, default 0
        Seed of the whole study (cell c, run r uses the r-th scene seed of cell c).
    progress : bool, default True
        Show a tqdm progress bar.
    background : ARFieldModel, optional
        Textured background of every scene (see :func:`kalmanfield.simulate_scene`).
    n_frames : int, default 10
        Frames per scene (the source's n + 1 = 10).
    **detector
        Extra keywords of :func:`kalmanfield.detect_moving_objects`.

    Returns
    -------
    pandas.DataFrame
        One row per cell: ``snr``, ``p_false``, ``runs``, ``correct``, ``p_o``, ``low``,
        ``high`` (95 % Wilson interval) and ``source`` (the source's P_o, NaN where it has
        none).

    Examples
    --------
    >>> from kalmanfield.experiments import k93
    >>> table = k93(snr=(5,), p_false=(0.1,), runs=4, progress=False)
    >>> list(table.columns)
    ['snr', 'p_false', 'runs', 'correct', 'p_o', 'low', 'high', 'source']
    """
    runs = positive_int(runs, "runs")
    cells = [(float(s), float(p)) for s in snr for p in p_false]
    root = np.random.SeedSequence(resolve_seed(seed))
    children = root.spawn(len(cells))
    rows = []
    bar = tqdm.tqdm(total=len(cells) * runs, disable=not progress, desc="k93")
    for (s, p), child in zip(cells, children):
        seeds = child.generate_state(runs, dtype=np.uint64)
        correct = 0
        for r in range(runs):
            scene = simulate_scene(
                (64, 64),
                n_frames,
                targets=1,
                snr=s,
                p_false=p,
                dt=0.1,
                background=background,
                seed=int(seeds[r]),
            )
            options = {"noise_std": 1.0, "dt": 0.1, **detector}
            correct += k93_correct(detect_moving_objects(scene.frames, **options), scene.truth)
            bar.update()
        low, high = (float(v) for v in _wilson(np.array(correct), runs))
        rows.append(
            (s, p, runs, correct, correct / runs, low, high, SOURCE_P_O.get((s, p), math.nan))
        )
    bar.close()
    return pd.DataFrame(
        rows, columns=["snr", "p_false", "runs", "correct", "p_o", "low", "high", "source"]
    )


def plot_k93(table: pd.DataFrame, ax: Any = None) -> Any:
    """P_o with its 95 % interval per cell of :func:`k93`, the source's values as crosses.

    Parameters
    ----------
    table : pandas.DataFrame
        The answer of :func:`k93`.
    ax : matplotlib.axes.Axes, optional
        Axes to draw in (default: a new figure).

    Returns
    -------
    matplotlib.axes.Axes
        The axes drawn in.

    Notes
    -----
    Needs matplotlib (an optional extra), imported when called.

    Examples
    --------
    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> from kalmanfield.experiments import k93, plot_k93
    >>> ax = plot_k93(k93(snr=(5,), p_false=(0.1,), runs=3, progress=False))
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(5, 3.2))
    for p, cell in table.groupby("p_false", sort=False):
        x = cell["snr"].to_numpy()
        y = cell["p_o"].to_numpy()
        err = np.vstack([y - cell["low"].to_numpy(), cell["high"].to_numpy() - y])
        ax.errorbar(x, y, yerr=err, marker="o", capsize=3, label=f"ours, P_f = {p:g}")
        ax.plot(x, cell["source"].to_numpy(), "x", markersize=9, label=f"[K93], P_f = {p:g}")
    ax.set_xlabel("SNR")
    ax.set_ylabel("P_o (correct detection)")
    ax.set_ylim(0, 1.02)
    ax.legend(fontsize=8)
    return ax
