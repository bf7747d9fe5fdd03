"""trackpy-style linking with the branching tracker (method page *Tracking*, §3.3): one call
on a detection table."""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from .._validation import real_array
from .branching_tracker import BranchingTracker
from .config import TrackerConfig

__all__ = ["link"]


#: frames a table may skip in total beyond 100 per detection (guards against a frame range
#: that would run for hours on empty frames, e.g. timestamps passed as frame numbers)
MAX_EMPTY_FRAMES = 1_000_000


def link(
    detections: pd.DataFrame,
    *,
    measurement_std: float | Sequence[float],
    process_std: float | Sequence[float],
    confidence: float = 0.99,
    memory: int = 4,
    max_misses: int = 2,
    dt: float = 1.0,
    features: Sequence[str] = (),
    pos_columns: Sequence[str] = ("x", "y"),
    progress: bool = False,
    **kwargs: Any,
) -> pd.DataFrame:
    """Link the detections of a table into tracks with the branching tracker.

    Parameters
    ----------
    detections : pandas.DataFrame
        A ``frame`` column (integers within int64; frames may skip, the skipped ones are
        empty), the `pos_columns` and the `features` columns (real numbers).
    measurement_std : float or sequence of float
        Measurement noise std per column (positions, then features), e.g. in px.
    process_std : float or sequence of float
        Std of the white random acceleration per column (px/frame², times `dt`).
    confidence : float, default 0.99
        Confidence β of the χ² gate.
    memory : int, default 4
        N, the index increments kept (sliding memory).
    max_misses : int, default 2
        Longest run of frames a track may coast.
    dt : float, default 1.0
        Time between consecutive frame numbers.
    features : sequence of str, default ()
        Further columns tracked as parameters (amplitude, area…).
    pos_columns : sequence of str, default ("x", "y")
        The position columns.
    progress : bool, default False
        Show a tqdm progress bar.
    **kwargs
        Any other setting of :class:`TrackerConfig` (``order=``, ``clutter_density=``…).

    Returns
    -------
    pandas.DataFrame
        A copy of `detections` (index kept) with a ``particle`` column: the track of each
        detection on a chosen confirmed sequence, −1 for the others (clutter,
        unconfirmed).

    Raises
    ------
    TypeError
        `detections` is not a DataFrame, a column name given as a string, complex, bool or
        string columns, an unknown setting.
    ValueError
        Missing or duplicated columns, frame numbers that are not integers within int64 or
        span far more frames than there are detections, NaN or infinite values, a setting
        out of range.

    See Also
    --------
    BranchingTracker : The tracker, frame by frame.

    Notes
    -----
    The model is a polynomial Kalman filter per column (order 1, nearly constant velocity,
    unless ``order=`` is given). Unless `clutter_density` is given it is estimated once from
    the whole table: detections per frame over the bounding box of the columns, an upper
    bound (targets included). Method: §3.1–3.3 of :doc:`/methods/tracking`.

    Examples
    --------
    >>> import pandas as pd
    >>> import kalmanfield as kf
    >>> rows = [{"frame": f, "x": 10 + 1.5 * f, "y": 20.0} for f in range(10)]
    >>> rows += [{"frame": f, "x": 40.0, "y": 5.0 + f} for f in range(10)]
    >>> linked = kf.link(pd.DataFrame(rows), measurement_std=0.5, process_std=0.1)
    >>> linked.groupby("particle").size().tolist()
    [10, 10]
    """
    if not isinstance(detections, pd.DataFrame):
        raise TypeError(f"detections must be a pandas DataFrame, got {type(detections).__name__}")
    for name, names in (("pos_columns", pos_columns), ("features", features)):
        if isinstance(names, (str, bytes)):  # ("xy" had been read as the columns x and y)
            raise TypeError(f"{name} must be a sequence of column names, got {names!r}")
    cols = [*pos_columns, *features]
    if not list(pos_columns):
        raise ValueError("pos_columns must name at least one position column")
    missing = [c for c in ["frame", *cols] if c not in detections.columns]
    if missing:
        raise ValueError(f"detections lack the columns {missing}")
    df = detections.reset_index(drop=True)
    frame_numbers = _frame_numbers(df["frame"].to_numpy())
    # Python ints: the int64 difference wraps round for frame numbers spanning int64
    span = int(frame_numbers.max()) - int(frame_numbers.min()) + 1 if len(df) else 0
    if span > MAX_EMPTY_FRAMES + 100 * len(df):
        raise ValueError(
            f"the frame numbers span {span} frames for {len(df)} detections (every frame in "
            "between is processed, empty ones too); renumber the frames"
        )
    values = _columns(df, cols)
    if not np.isfinite(values).all():
        raise ValueError(f"the columns {cols} must be finite (drop NaN rows first)")
    if kwargs.get("clutter_density") is None and len(df):
        kwargs["clutter_density"] = table_clutter_density(values, frame_numbers)
    settings = dict(
        process_std=process_std,
        measurement_std=measurement_std,
        confidence=confidence,
        memory=memory,
        max_misses=max_misses,
        dt=dt,
        n_spatial=len(pos_columns),
    )
    config = TrackerConfig.from_settings({**settings, **kwargs}, caller="link")
    tracker = BranchingTracker(len(cols), config, names=cols)
    out = detections.copy()
    particle = np.full(len(df), -1, np.int64)
    out["particle"] = particle
    if not len(df):
        return out
    order = np.argsort(frame_numbers, kind="stable")
    first, last = int(frame_numbers.min()), int(frame_numbers.max())
    bounds = np.searchsorted(frame_numbers[order], np.arange(first, last + 2))
    frames = range(first, last + 1)
    if progress:
        from tqdm.auto import tqdm

        frames = tqdm(frames, desc="link", unit="frame")
    for f in frames:
        rows = order[bounds[f - first] : bounds[f - first + 1]]
        tracker.update(values[rows], time=(f - first) * tracker.config.dt)
    tracks = tracker.tracks()
    hit = tracks["detection"].to_numpy() >= 0
    # global detection ids run over the frames in order, rows within a frame in `order`
    particle[order[tracks["detection"].to_numpy()[hit]]] = tracks["particle"].to_numpy()[hit]
    out["particle"] = particle
    return out


def _frame_numbers(column: np.ndarray) -> np.ndarray:
    """The frame column as int64: integers (not bools), or floats / Python objects holding
    integral values within int64; anything else (strings, datetimes, fractions, NaN, bools,
    numbers beyond int64) is a ValueError."""
    bad = ValueError(
        f"the frame column must hold integer frame numbers within int64, got dtype {column.dtype}"
    )
    if np.issubdtype(column.dtype, np.integer):
        if column.dtype.kind == "u" and column.size and column.max() >= 2**63:
            raise bad  # (astype wrapped them round to negative frames)
        return column.astype(np.int64)
    limit = float(2**63)
    if column.dtype.kind == "f":
        with np.errstate(invalid="ignore"):
            ok = np.isfinite(column) & (column == np.round(column)) & (np.abs(column) < limit)
        if not ok.all():
            raise bad
        return column.astype(np.int64)
    if column.dtype.kind != "O":
        raise bad
    for f in column:
        if isinstance(f, (bool, np.bool_)) or not isinstance(f, numbers.Real):
            raise bad
        if isinstance(f, numbers.Integral):
            if not -(2**63) <= int(f) < 2**63:
                raise bad
        else:
            value = float(f)
            if not (math.isfinite(value) and value.is_integer() and -limit <= value < limit):
                raise bad
    return np.array([int(f) for f in column], dtype=np.int64)


def _columns(df: pd.DataFrame, cols: list[str]) -> np.ndarray:
    """The position and feature columns as an (n, k) float64 array, each checked as
    :func:`real_array` checks arrays (complex, bool, strings, numeric strings too: TypeError
    naming the column); pandas' nullable numeric columns give NaN for their missing values."""
    out = np.empty((len(df), len(cols)))
    for q, name in enumerate(cols):
        series = df[name]
        if isinstance(series, pd.DataFrame):
            raise ValueError(f"detections have more than one column named {name!r}")
        dtype = series.dtype
        if isinstance(dtype, pd.api.extensions.ExtensionDtype) and dtype.kind in "iuf":
            column = series.to_numpy(dtype=np.float64, na_value=np.nan)
        else:
            column = series.to_numpy()
        out[:, q] = real_array(column, f"column {name!r}")
    return out


def table_clutter_density(values: np.ndarray, frame_numbers: np.ndarray) -> float:
    """Detections per frame (at least 1) per unit of the bounding box of `values` (n, k)
    (each side at least 1): the clutter density estimate of :func:`link`."""
    n_frames = int(frame_numbers.max()) - int(frame_numbers.min()) + 1
    rate = max(len(values) / n_frames, 1.0)
    with np.errstate(over="ignore"):  # a box beyond float64 is as good as an infinite one
        spans = np.maximum(values.max(axis=0) - values.min(axis=0), 1.0)
        density = rate / np.prod(spans)
    # kept positive (the tracker needs one) however wide the box
    return float(max(density, np.finfo(float).tiny))
