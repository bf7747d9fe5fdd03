"""Checks shared by :func:`match_template` and :class:`TemplateTracker`: frames, templates and
windows become the arrays and tuples the Rust kernels take, or a clear exception."""

from __future__ import annotations

import numbers
from typing import Any

import numpy as np
import numpy.typing as npt

#: pixel types the kernels read as they are (other real dtypes are converted to float64)
KERNEL_DTYPES = frozenset(np.dtype(t) for t in (np.uint8, np.uint16, np.float32, np.float64))

Window = tuple[int, int, int, int]


def pixel_dtype(dtype: np.dtype) -> np.dtype:
    """The dtype a frame of `dtype` is searched in: bool → uint8, the kernel dtypes in native
    byte order, any other real dtype → float64; TypeError for non-real dtypes."""
    if dtype.kind not in "biuf":
        raise TypeError(f"pixels must be real numbers, got dtype {dtype}")
    if dtype.kind == "b":
        return np.dtype(np.uint8)
    native = dtype.newbyteorder("=")
    return native if native in KERNEL_DTYPES else np.dtype(np.float64)


def frame_array(frame: npt.ArrayLike, name: str = "frame") -> np.ndarray:
    """`frame` as a 2-D C-contiguous array of a kernel dtype (no copy when it already is)."""
    if isinstance(frame, np.ma.MaskedArray):
        frame = np.ma.filled(frame.astype(np.float64), np.nan)
    arr = np.asarray(frame)
    target = pixel_dtype(arr.dtype)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D, got {arr.ndim} dimensions (shape {arr.shape})")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    return np.ascontiguousarray(arr, dtype=target)


def template_array(template: npt.ArrayLike, dtype: np.dtype) -> np.ndarray:
    """A template for frames of the kernel dtype `dtype`, as float64 (the kernels' copy).

    A NumPy array must have the frame's dtype (after the same conversion as the frame:
    bool → uint8, other real dtypes → float64): TypeError otherwise. Any other array-like is
    taken in the frame's dtype if its values are exactly representable there.
    """
    if isinstance(template, np.ndarray):
        arr = template
        if pixel_dtype(arr.dtype) != dtype:
            raise TypeError(
                f"the template's dtype {arr.dtype} does not match the frame's {dtype}; convert "
                f"one of them (e.g. template.astype(frame.dtype))"
            )
    else:
        arr = np.asarray(template)
        if arr.dtype.kind not in "biuf":
            raise TypeError(f"template must hold real numbers, got dtype {arr.dtype}")
        with np.errstate(all="ignore"):
            cast = arr.astype(dtype)
        exact = np.array_equal(cast.astype(np.float64), arr.astype(np.float64), equal_nan=True)
        if not exact:
            raise TypeError(
                f"the template's values are not exactly representable in the frame's dtype "
                f"{dtype}; pass the template as an array of that dtype"
            )
    if arr.ndim != 2:
        raise ValueError(f"template must be 2-D, got {arr.ndim} dimensions (shape {arr.shape})")
    if arr.size == 0:
        raise ValueError(f"template is empty (shape {arr.shape})")
    return np.ascontiguousarray(arr, dtype=np.float64)


def window_tuple(window: Any, name: str = "window") -> Window:
    """(x0, y0, x1, y1) as four non-negative ints (half-open: x1, y1 exclusive)."""
    try:
        values = list(window)
    except TypeError:
        raise TypeError(f"{name} must be a sequence (x0, y0, x1, y1), got {window!r}") from None
    if len(values) != 4:
        raise ValueError(f"{name} must have 4 entries (x0, y0, x1, y1), got {len(values)}")
    out = []
    for v in values:
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral):
            raise TypeError(f"{name} entries must be integers, got {v!r}")
        if not 0 <= int(v) < 2**63:
            raise ValueError(f"{name} entries must be non-negative, got {int(v)}")
        out.append(int(v))
    x0, y0, x1, y1 = out
    return x0, y0, x1, y1


def method_name(method: Any) -> str:
    """'ncc' or 'correlation'."""
    if method not in ("ncc", "correlation"):
        raise ValueError(f"method must be 'ncc' or 'correlation', got {method!r}")
    return str(method)
