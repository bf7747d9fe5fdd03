"""Segmentation of one frame into bright spots: threshold and connected components (method
page *Tracking*, §3; [K93]); the Rust kernel ``_core.segment``."""

from __future__ import annotations

import numbers
from collections.abc import Callable
from typing import Any, Literal, Union, overload

import numpy as np
import numpy.typing as npt
import pandas as pd

from .. import _core
from .._channels import check_channel_axis, warn_if_colour
from .._validation import positive_int, real_number

#: columns of the segment table, in order (``frame`` comes first when ``frame_no`` is given)
COLUMNS = (
    "x",
    "y",
    "amplitude",
    "area",
    "extent_x",
    "extent_y",
    "bbox_x0",
    "bbox_y0",
    "bbox_x1",
    "bbox_y1",
    "label",
)
_INT_COLUMNS = frozenset({"area", "bbox_x0", "bbox_y0", "bbox_x1", "bbox_y1", "label"})
#: a threshold: a number, "otsu" or a function of the image
Threshold = Union[float, str, Callable[[np.ndarray], float]]
_KERNEL_DTYPES = frozenset(np.dtype(t) for t in (np.uint8, np.uint16, np.float32, np.float64))


@overload
def segment(
    frame: npt.ArrayLike,
    threshold: Threshold,
    min_area: int = ...,
    connectivity: int = ...,
    *,
    labels: Literal[False] = ...,
    frame_no: int | None = ...,
    channel_axis: int | None = ...,
) -> pd.DataFrame: ...
@overload
def segment(
    frame: npt.ArrayLike,
    threshold: Threshold,
    min_area: int = ...,
    connectivity: int = ...,
    *,
    labels: Literal[True],
    frame_no: int | None = ...,
    channel_axis: int | None = ...,
) -> tuple[pd.DataFrame, np.ndarray]: ...
def segment(
    frame: npt.ArrayLike,
    threshold: Threshold,
    min_area: int = 1,
    connectivity: int = 8,
    *,
    labels: bool = False,
    frame_no: int | None = None,
    channel_axis: int | None = None,
) -> pd.DataFrame | tuple[pd.DataFrame, np.ndarray]:
    """Segments of a frame: the connected components of the pixels above a threshold.

    Parameters
    ----------
    frame : array_like
        A 2-D frame, or a 3-D stack of frames (segmented in parallel, GIL released; the
        table then has a ``frame`` column). uint8, uint16, float32 and float64 are used as
        they are, bool as uint8, other numeric types as float64.
    threshold : float, "otsu" or callable
        A pixel of value v is foreground iff v > threshold; its weight is v − threshold.
        "otsu": Otsu's threshold of the frame's (the stack's) 256-bin histogram, as
        ``skimage.filters.threshold_otsu``; a callable gets the frame (or the whole stack)
        and returns the threshold.
    min_area : int, default 1
        Segments of fewer pixels are dropped.
    connectivity : {8, 4}, default 8
        Foreground pixels connect through their 4 edge neighbours, or also their 4 corner
        neighbours.
    labels : bool, default False
        Also return the int32 label image (0 = background).
    frame_no : int, optional
        If given, a first column ``frame`` holding it (for a stack: it plus the index in
        the stack), the trackpy convention.
    channel_axis : int, optional
        The axis of colour channels: they are averaged into one intensity image before
        segmenting (segment a channel alone by passing it alone). Without it, a 3-D array
        ending in 3 or 4 values warns: it is read as a stack of narrow frames.

    Returns
    -------
    table : pandas.DataFrame
        One row per segment, in label order: (``frame``,) ``x``, ``y`` (centroid weighted by
        the excess over the threshold; pixel (r, c) has centre x = c, y = r),
        ``amplitude`` (mean pixel value), ``area`` (pixel count), ``extent_x``,
        ``extent_y`` (RMS half-sizes √(Σ w (x − x̄)² / Σ w)), ``bbox_x0``, ``bbox_y0``,
        ``bbox_x1``, ``bbox_y1`` (inclusive) and ``label`` (1..n in raster order of each
        segment's first pixel). Integer columns are int64, the others float64.
    label_image : numpy.ndarray
        The label image, of the frame's shape; only with ``labels=True``.

    Raises
    ------
    TypeError
        Complex, object or string frames; parameters of the wrong type.
    ValueError
        Frames that are not 2-D or 3-D, NaN or infinite pixels, pixels so large (≳ 1e300)
        that the segment moments overflow, a bad threshold, `min_area`, `connectivity` or
        `frame_no`.

    See Also
    --------
    BranchingTracker : Tracks the segments' parameter vectors.

    Notes
    -----
    One raster scan over runs of foreground pixels with union–find (Rust). See §3 of
    :doc:`/methods/tracking`.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> frame = np.zeros((32, 32))
    >>> frame[5:8, 10:13] = 100.0
    >>> kf.segment(frame, threshold=25)[["x", "y", "area"]]
          x    y  area
    0  11.0  6.0     9
    """
    image = _frame_array(frame, channel_axis)
    t = _threshold(threshold, image)
    area = positive_int(min_area, "min_area")
    conn = _connectivity(connectivity)
    frame_no = _frame_no(frame_no, image.shape[0] if image.ndim == 3 else 1)
    if image.ndim == 3:
        return _segment_stack(image, t, area, conn, frame_no or 0, labels)
    if image.size == 0:
        columns, label_image = _empty_columns(), np.zeros(image.shape, dtype=np.int32)
    else:
        columns, label_image = _core.segment(image, t, area, conn)
    _check_moments(columns)
    table = _table(columns, frame_no)
    return (table, label_image) if labels else table


def _frame_array(frame: npt.ArrayLike, channel_axis: int | None = None) -> np.ndarray:
    """The frame as a C-contiguous, native-byte-order 2-D array of a kernel dtype (the mean
    of its channels if `channel_axis`)."""
    arr = np.asarray(frame)
    kind = arr.dtype.kind
    if kind not in "biuf":
        raise TypeError(f"frame must hold real numbers, got dtype {arr.dtype}")
    axis = check_channel_axis(channel_axis, arr.ndim)
    if axis is None:
        warn_if_colour(arr, "segment")
    else:
        arr = arr.mean(axis=axis)
        kind = arr.dtype.kind
    if arr.ndim not in (2, 3):
        raise ValueError(
            f"frame must be 2-D (or a 3-D stack), got {arr.ndim} dimensions (shape {arr.shape})"
        )
    target: np.dtype[Any]
    if kind == "b":
        target = np.dtype(np.uint8)
    elif arr.dtype.newbyteorder("=") in _KERNEL_DTYPES:
        target = arr.dtype.newbyteorder("=")
    else:
        target = np.dtype(np.float64)
    return np.ascontiguousarray(arr, dtype=target)


def _segment_stack(
    stack: np.ndarray, t: float, area: int, conn: int, first: int, labels: bool
) -> pd.DataFrame | tuple[pd.DataFrame, np.ndarray]:
    if stack.size == 0:
        columns = _empty_columns()
        frames = np.zeros(0, dtype=np.int64)
        label_image = np.zeros(stack.shape, dtype=np.int32)
    else:
        columns, label_image = _core.segment_stack(stack, t, area, conn)
        _check_moments(columns)
        frames = columns["frame"]
    data = {"frame": frames + first, **{name: columns[name] for name in COLUMNS}}
    table = pd.DataFrame(data, copy=False)
    return (table, label_image) if labels else table


def _threshold(threshold: object, image: np.ndarray) -> float:
    """The threshold: a number, Otsu's ("otsu") or what a callable makes of the image."""
    if isinstance(threshold, str):
        if threshold != "otsu":
            raise ValueError(f"threshold must be a number, 'otsu' or a callable, got {threshold!r}")
        return otsu_threshold(image)
    if callable(threshold):
        return real_number(threshold(image), "the threshold the callable returned")
    return real_number(threshold, "threshold")


def otsu_threshold(image: npt.ArrayLike, bins: int = 256) -> float:
    """Otsu's threshold: the bin centre that maximises the between-class variance of the
    image's `bins`-bin histogram (``skimage.filters.threshold_otsu``'s definition).

    Parameters
    ----------
    image : array_like
        Finite pixel values, any shape.
    bins : int, default 256
        Histogram bins over [min, max].

    Returns
    -------
    float
        The threshold (the pixels above it are the foreground).

    Raises
    ------
    ValueError
        An empty or constant image (no threshold separates it), non-finite pixels.

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield.tracking.segment import otsu_threshold
    >>> otsu_threshold(np.r_[np.zeros(50), np.ones(50)]) < 1.0
    True
    """
    values = np.asarray(image, dtype=np.float64).ravel()
    if values.size == 0 or not np.isfinite(values).all():
        raise ValueError("Otsu's threshold needs a non-empty image of finite pixels")
    if values.min() == values.max():
        raise ValueError("Otsu's threshold of a constant image is undefined: give a number")
    counts, edges = np.histogram(values, bins=bins)
    centres = (edges[:-1] + edges[1:]) / 2
    weight_low = np.cumsum(counts)
    weight_high = np.cumsum(counts[::-1])[::-1]
    mean_low = np.cumsum(counts * centres) / weight_low
    mean_high = (np.cumsum((counts * centres)[::-1]) / weight_high[::-1])[::-1]
    between = weight_low[:-1] * weight_high[1:] * (mean_low[:-1] - mean_high[1:]) ** 2
    return float(centres[:-1][np.argmax(between)])


def _connectivity(value: object) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"connectivity must be 4 or 8, got {value!r}")
    if int(value) not in (4, 8):
        raise ValueError(f"connectivity must be 4 or 8, got {int(value)}")
    return int(value)


def _frame_no(value: object, frames: int) -> int | None:
    """The first frame number; the `frames` numbers from it must fit the int64 column."""
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"frame_no must be an integer or None, got {value!r}")
    if not -(2**63) <= int(value) <= 2**63 - max(frames, 1):
        raise ValueError(f"the frame numbers from frame_no={int(value)} overflow int64")
    return int(value)


def _check_moments(columns: dict[str, np.ndarray]) -> None:
    """ValueError when a segment's moments left float64 (their sums of pixel weights
    v − threshold times coordinates overflow for weights ≳ 1e300): one check per segment,
    not per pixel."""
    moments = (columns[name] for name in COLUMNS if name not in _INT_COLUMNS)
    if not all(np.isfinite(m).all() for m in moments):
        raise ValueError(
            "a segment's moments overflow float64 (its pixel values or their excess over the "
            "threshold ≳ 1e300): rescale the frame, or raise a threshold that far below them"
        )


def _empty_columns() -> dict[str, np.ndarray]:
    return {
        name: np.empty(0, dtype=np.int64 if name in _INT_COLUMNS else np.float64)
        for name in COLUMNS
    }


def _table(columns: dict[str, np.ndarray], frame_no: int | None) -> pd.DataFrame:
    data = {name: columns[name] for name in COLUMNS}
    if frame_no is not None:
        data = {"frame": np.full(len(columns["label"]), frame_no, dtype=np.int64), **data}
    return pd.DataFrame(data, copy=False)
