"""The lazy imports of dask (an optional extra) and the frame-stack checks shared here."""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np

from ..io._optional import optional


def dask_array() -> ModuleType:
    return optional("dask.array", "kalmanfield.dask")


def as_frames(frames: Any, name: str = "frames") -> Any:
    """`frames` as a 3-D dask array (F, H, W) chunked along axis 0 only (whole frames: the
    row filters and the segmentation need every pixel of a frame). NumPy arrays and zarr
    arrays are wrapped without a copy."""
    da = dask_array()
    arr = frames if isinstance(frames, da.Array) else da.asarray(frames)
    if arr.ndim != 3:
        raise ValueError(f"{name} must be a stack (F, H, W), got {arr.ndim} dimensions")
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"{name} must be real numbers, got dtype {arr.dtype}")
    if len(arr.chunks[1]) > 1 or len(arr.chunks[2]) > 1:
        arr = arr.rechunk({1: -1, 2: -1})
    return arr


def chunk_starts(chunks: tuple[int, ...]) -> list[int]:
    """The index of the first frame of every chunk along axis 0."""
    return [int(s) for s in np.cumsum((0, *chunks[:-1]))]
