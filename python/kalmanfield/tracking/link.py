"""trackpy-style linking with the branching tracker (method page *Tracking*, §3.3 and §3.6):
one call on a detection table, the noise levels estimated from it when not given."""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import pandas as pd

from .._validation import real_array
from .branching_tracker import BranchingTracker
from .config import TrackerConfig
from .noise_levels import MotionNoise, estimate_motion_noise, pilot_noise

__all__ = ["link"]


#: frames a table may skip in total beyond 100 per detection (guards against a frame range
#: that would run for hours on empty frames, e.g. timestamps passed as frame numbers)
MAX_EMPTY_FRAMES = 1_000_000


#: the motion models of ``link(motion=...)``
MOTIONS = ("auto", "velocity", "diffusion")

#: trackpy's arguments that mean something else here (the hint of the TypeError)
TRACKPY_HINTS = {
    "search_range": "its gates follow from the noise levels (measurement_std, process_std, "
    "diffusion_std; estimated from the data when not given)",
    "adaptive_stop": "its gates follow from the noise levels",
    "adaptive_step": "its gates follow from the noise levels",
    "neighbor_strategy": "the tracker finds the gated detections itself",
    "link_strategy": "the tracker branches over every gated detection",
}


def link(
    detections: pd.DataFrame,
    *,
    measurement_std: float | Sequence[float] | None = None,
    process_std: float | Sequence[float] | None = None,
    diffusion_std: float | Sequence[float] | None = None,
    motion: str = "auto",
    confidence: float = 0.999,
    memory: int = 4,
    max_misses: int = 3,
    dt: float = 1.0,
    features: Sequence[str] = (),
    pos_columns: Sequence[str] | None = None,
    t_column: str = "frame",
    keep_unlinked: bool = False,
    progress: bool = False,
    **kwargs: Any,
) -> pd.DataFrame:
    """Link the detections of a table into tracks with the branching tracker.

    Parameters
    ----------
    detections : pandas.DataFrame
        The `t_column` (integers within int64; frames may skip, the skipped ones are
        empty), the `pos_columns` and the `features` columns (real numbers).
    measurement_std : float or sequence of float, optional
        Measurement noise std per column (positions, then features), e.g. in px. Estimated
        from the data when not given (Notes).
    process_std : float or sequence of float, optional
        Std of the white random acceleration per column (px/frame², times `dt`). Estimated
        when not given; 0 with ``motion="diffusion"``.
    diffusion_std : float or sequence of float, optional
        Std of the random walk (Brownian motion) per column and unit time (px/frame^½).
        Estimated when not given; 0 with ``motion="velocity"``.
    motion : {"auto", "velocity", "diffusion"}, default "auto"
        The motion model: ``"auto"`` drift plus diffusion (nearly constant velocity with a
        random walk on the position: directed and Brownian particles alike),
        ``"velocity"`` nearly constant velocity (no diffusion), ``"diffusion"`` Brownian
        motion (order 0, no velocity).
    confidence : float, default 0.999
        Confidence β of the χ² gate (the tracker's default is 0.99: here one wrong gate
        costs a link, and the score keeps the clutter the wider gate admits out).
    memory : int, default 4
        N, the index increments kept (sliding memory). Not trackpy's `memory`, which is
        `max_misses` here.
    max_misses : int, default 3
        Longest run of frames a track may coast (trackpy's `memory`).
    dt : float, default 1.0
        Time between consecutive frame numbers.
    features : sequence of str, default ()
        Further columns tracked as parameters (amplitude, area…).
    pos_columns : sequence of str, optional
        The position columns (default, as trackpy guesses them: ``("x", "y", "z")`` when
        there is a ``z`` column, else ``("x", "y")``).
    t_column : str, default "frame"
        The frame-number column (trackpy's name for it).
    keep_unlinked : bool, default False
        Keep the detections on no track (clutter, unconfirmed) with ``particle`` −1; by
        default they are dropped, so that trackpy's tools (``filter_stubs``, ``imsd``,
        ``plot_traj``) take the table as it is.
    progress : bool, default False
        Show a tqdm progress bar.
    **kwargs
        Any other setting of :class:`TrackerConfig` (``order=``, ``max_speed=``,
        ``clutter_density=``…).

    Returns
    -------
    pandas.DataFrame
        The rows of `detections` on a track (all of them with `keep_unlinked`), index kept,
        with a ``particle`` column (int64). ``attrs["tracker_config"]`` holds the
        :class:`TrackerConfig` used, estimated settings included (None for an empty table).

    Raises
    ------
    TypeError
        `detections` is not a DataFrame, a column name given as a string, complex, bool or
        string columns, an unknown setting (trackpy's `search_range` with a hint).
    ValueError
        Missing or duplicated columns, frame numbers that are not integers within int64 or
        span far more frames than there are detections, NaN or infinite values, a setting
        out of range, an unknown `motion` or settings it contradicts.

    See Also
    --------
    BranchingTracker : The tracker, frame by frame.

    Notes
    -----
    Settings not given are derived from the table (method page :doc:`/methods/tracking`,
    §3.6). A pilot run with noise levels scaled by the mean spacing L of the detections
    (σ_m = σ_a = L/60, σ_D = L/20, largest speed L/3) links them once; the second
    differences along its tracks give, per column, the measurement noise, the random
    acceleration and the diffusion (robust autocovariances at lags 0–2, solved for the
    three variances), and their steps the largest speed (twice the 99th percentile);
    the manoeuvre branch (velocity jumps of std ``max_speed / 4`` on the positions) is on
    unless ``maneuver_std=None``. Then the final run. No pilot runs when the three noise
    levels (as `motion` needs them) and ``max_speed`` are given. Unless `clutter_density`
    is given it is estimated from the whole table: detections per frame over the bounding
    box of the columns, an upper bound (targets included).

    Examples
    --------
    >>> import pandas as pd
    >>> import kalmanfield as kf
    >>> rows = [{"frame": f, "x": 10 + 1.5 * f, "y": 20.0} for f in range(10)]
    >>> rows += [{"frame": f, "x": 40.0, "y": 5.0 + f} for f in range(10)]
    >>> linked = kf.link(pd.DataFrame(rows))
    >>> linked.groupby("particle").size().tolist()
    [10, 10]
    """
    if not isinstance(detections, pd.DataFrame):
        raise TypeError(f"detections must be a pandas DataFrame, got {type(detections).__name__}")
    _refuse_trackpy_arguments(kwargs)
    if pos_columns is None:
        pos_columns = ("x", "y", "z") if "z" in detections.columns else ("x", "y")
    for name, names in (("pos_columns", pos_columns), ("features", features)):
        if isinstance(names, (str, bytes)):  # ("xy" had been read as the columns x and y)
            raise TypeError(f"{name} must be a sequence of column names, got {names!r}")
    if not isinstance(t_column, str):
        raise TypeError(f"t_column must be a column name (str), got {t_column!r}")
    cols = [*pos_columns, *features]
    if not list(pos_columns):
        raise ValueError("pos_columns must name at least one position column")
    missing = [c for c in [t_column, *cols] if c not in detections.columns]
    if missing:
        raise ValueError(f"detections lack the columns {missing}")
    df = detections.reset_index(drop=True)
    frame_numbers = _frame_numbers(df[t_column].to_numpy(), t_column)
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
        measurement_std=measurement_std,
        process_std=process_std,
        diffusion_std=diffusion_std,
        confidence=confidence,
        memory=memory,
        max_misses=max_misses,
        dt=dt,
        n_spatial=len(pos_columns),
        **kwargs,
    )
    settings = _motion_settings(motion, settings)
    config = TrackerConfig.from_settings(
        {**settings, **{n: 1.0 for n in NOISE_LEVELS if settings[n] is None}}, caller="link"
    )
    config.for_params(len(cols))  # bad settings fail before the pilot
    used: TrackerConfig | None = None
    particle = np.full(len(df), -1, np.int64)
    if len(df):
        if any(settings.get(n) is None for n in (*NOISE_LEVELS, "max_speed")):
            used = _estimated_config(
                settings, values, frame_numbers, len(pos_columns), cols, config.dt, progress
            )
        else:
            used = TrackerConfig.from_settings(settings, caller="link")
        particle = _run(used, values, frame_numbers, cols, progress)
    out = detections.copy()
    out["particle"] = particle
    if not keep_unlinked:
        out = out[particle >= 0]
    out.attrs["tracker_config"] = used
    return out


#: the settings link derives from the data when they are not given
NOISE_LEVELS = ("measurement_std", "process_std", "diffusion_std")


def _refuse_trackpy_arguments(kwargs: dict[str, Any]) -> None:
    """trackpy's linking arguments get a TypeError that says what replaces them."""
    known = [n for n in kwargs if n in TRACKPY_HINTS]
    if known:
        name = known[0]
        raise TypeError(
            f"link got trackpy's argument {name!r}: kalmanfield's link has none, "
            f"{TRACKPY_HINTS[name]}; trackpy's memory is max_misses here"
        )


def _motion_settings(motion: str, settings: dict[str, Any]) -> dict[str, Any]:
    """The settings a motion model fixes: order 1 (auto, velocity) or 0 (diffusion), no
    diffusion (velocity) or no acceleration (diffusion)."""
    if motion not in MOTIONS:
        raise ValueError(f"motion must be one of {MOTIONS}, got {motion!r}")
    out = dict(settings)
    if motion == "auto":
        out.setdefault("order", 1)
        return out
    if "order" in settings:
        raise ValueError(f"give either motion={motion!r} or order=, not both")
    zero, order = ("diffusion_std", 1) if motion == "velocity" else ("process_std", 0)
    if _positive(settings[zero]):
        raise ValueError(f"motion={motion!r} has no {zero}; got {zero}={settings[zero]!r}")
    out[zero] = 0.0
    out["order"] = order
    return out


def _positive(value: Any) -> bool:
    return value is not None and bool(np.any(np.asarray(value, dtype=float) != 0))


def _estimated_config(
    settings: dict[str, Any],
    values: np.ndarray,
    frame_numbers: np.ndarray,
    n_spatial: int,
    cols: list[str],
    dt: float,
    progress: bool,
) -> TrackerConfig:
    """The configuration with the settings not given estimated from a pilot run (§3.6):
    noise levels per frame step, converted to time units with `dt`."""
    pilot = pilot_noise(values, frame_numbers, n_spatial)
    fill = _in_time_units(pilot, dt)
    pilot_settings = {n: fill[n] if settings.get(n) is None else settings[n] for n in fill}
    pilot_config = TrackerConfig.from_settings({**settings, **pilot_settings}, caller="link")
    particle = _run(pilot_config, values, frame_numbers, cols, progress, desc="link (pilot)")
    estimate = estimate_motion_noise(values, frame_numbers, particle, n_spatial, pilot)
    fill = _in_time_units(estimate, dt)
    final = {n: fill[n] if settings.get(n) is None else settings[n] for n in fill}
    return TrackerConfig.from_settings({**settings, **final}, caller="link")


#: the largest noise level the tracker takes (its filters square them); estimates from tables
#: of absurd coordinates are capped there, so that `link` still answers
_MAX_LEVEL = 1e100


def _in_time_units(noise: MotionNoise, dt: float) -> dict[str, Any]:
    """Settings from noise levels per frame step: σ_a / dt², σ_D / √dt, speed / dt."""

    def capped(values: Any) -> Any:
        return tuple(min(float(v), _MAX_LEVEL) for v in np.atleast_1d(values))

    return {
        "measurement_std": capped(noise.measurement_std),
        "process_std": capped([v / dt**2 for v in noise.process_std]),
        "diffusion_std": capped([v / math.sqrt(dt) for v in noise.diffusion_std]),
        "max_speed": min(noise.max_speed / dt, _MAX_LEVEL),
    }


def _run(
    config: TrackerConfig,
    values: np.ndarray,
    frame_numbers: np.ndarray,
    cols: list[str],
    progress: bool,
    desc: str = "link",
) -> np.ndarray:
    """The particle of each row (−1 on no track) after one run of the tracker."""
    particle = np.full(len(values), -1, np.int64)
    tracker = BranchingTracker(len(cols), config, names=cols)
    order = np.argsort(frame_numbers, kind="stable")
    first, last = int(frame_numbers.min()), int(frame_numbers.max())
    bounds = np.searchsorted(frame_numbers[order], np.arange(first, last + 2))
    frames: Iterable[int] = range(first, last + 1)
    if progress:
        from tqdm.auto import tqdm

        frames = tqdm(frames, desc=desc, unit="frame")
    for f in frames:
        rows = order[bounds[f - first] : bounds[f - first + 1]]
        tracker.update(values[rows], time=(f - first) * tracker.config.dt)
    tracks = tracker.tracks()
    hit = tracks["detection"].to_numpy() >= 0
    # global detection ids run over the frames in order, rows within a frame in `order`
    particle[order[tracks["detection"].to_numpy()[hit]]] = tracks["particle"].to_numpy()[hit]
    return particle


def _frame_numbers(column: np.ndarray, name: str = "frame") -> np.ndarray:
    """The frame column as int64: integers (not bools), or floats / Python objects holding
    integral values within int64; anything else (strings, datetimes, fractions, NaN, bools,
    numbers beyond int64) is a ValueError."""
    bad = ValueError(
        f"the {name} column must hold integer frame numbers within int64, got dtype {column.dtype}"
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
