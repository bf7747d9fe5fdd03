"""Zarr stores of frames: chunked on disk, read and written a chunk at a time."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, Union

import numpy as np
import numpy.typing as npt

from ._optional import optional

ZARR_SUFFIXES = (".zarr",)
PathLike = Union[str, Path]

#: target bytes of a chunk when none is given (zarr's advice: 1–100 MB uncompressed)
CHUNK_BYTES = 16 * 2**20


def default_chunks(
    frame_shape: tuple[int, ...], dtype: npt.DTypeLike, n_frames: int | None = None
) -> tuple[int, ...]:
    """Whole frames, as many per chunk as fit in CHUNK_BYTES (at least one, at most
    `n_frames`)."""
    frame_bytes = int(np.prod(frame_shape, dtype=np.int64)) * np.dtype(dtype).itemsize
    per_chunk = max(1, CHUNK_BYTES // max(frame_bytes, 1))
    if n_frames:
        per_chunk = min(per_chunk, n_frames)
    return (per_chunk, *frame_shape)


def open_zarr(path: PathLike) -> Any:
    """Open a zarr array for reading (nothing is loaded until sliced).

    Parameters
    ----------
    path : str or pathlib.Path
        The store (a ``.zarr`` folder) holding one array.

    Returns
    -------
    zarr.Array
        The array; ``array[t]`` reads frame t.

    Raises
    ------
    FileNotFoundError
        No such store.
    ValueError
        The path is not a zarr array.
    ImportError
        zarr is not installed (the ``io`` extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/frames.zarr"
    >>> _ = io.write_zarr(path, np.zeros((4, 16, 16)), chunks=(2, 16, 16))
    >>> io.open_zarr(path).chunks
    (2, 16, 16)
    """
    zarr = optional("zarr", "reading a zarr store")
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"no such zarr store: {p}")
    try:
        array = zarr.open_array(store=str(p), mode="r")
    except Exception as err:  # zarr's errors differ between versions
        raise ValueError(f"{p} is not a zarr array: {type(err).__name__}: {err}") from err
    return array


def write_zarr(
    path: PathLike,
    frames: npt.ArrayLike | Iterable[np.ndarray],
    *,
    chunks: tuple[int, ...] | None = None,
) -> Any:
    """Write frames into a new zarr array (an existing one at `path` is replaced).

    Parameters
    ----------
    path : str or pathlib.Path
        The store (a ``.zarr`` folder).
    frames : array_like or iterable of arrays
        A stack (F, …), or an iterable of frames written one at a time, so a stack larger
        than memory streams.
    chunks : tuple of int, optional
        Chunk shape; default whole frames, ~16 MB per chunk.

    Returns
    -------
    zarr.Array
        The written array.

    Raises
    ------
    ValueError
        No frame, or frames of different shapes or dtypes.
    ImportError
        zarr is not installed (the ``io`` extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/frames.zarr"
    >>> io.write_zarr(path, (np.full((8, 8), t) for t in range(3))).shape
    (3, 8, 8)
    """
    zarr = optional("zarr", "writing a zarr store")
    p = Path(path)
    if isinstance(frames, np.ndarray) or hasattr(frames, "__array__"):
        stack = np.asarray(frames)
        if stack.ndim < 1 or stack.size == 0:
            raise ValueError(f"no frame to write (shape {stack.shape})")
        array = zarr.open_array(
            store=str(p),
            mode="w",
            shape=stack.shape,
            dtype=stack.dtype,
            chunks=chunks or default_chunks(stack.shape[1:], stack.dtype, stack.shape[0]),
        )
        array[...] = stack
        return array
    return _append_frames(zarr, p, iter(frames), chunks)  # type: ignore[arg-type]


def _append_frames(zarr: Any, path: Path, frames: Any, chunks: tuple[int, ...] | None) -> Any:
    first = next(frames, None)
    if first is None:
        raise ValueError("no frame to write")
    first = np.asarray(first)
    shape = (0, *first.shape)
    size = chunks or default_chunks(first.shape, first.dtype)
    array = zarr.open_array(store=str(path), mode="w", shape=shape, dtype=first.dtype, chunks=size)
    batch: list[np.ndarray] = [first]
    for frame in frames:
        frame = np.asarray(frame)
        if frame.shape != first.shape:
            raise ValueError(f"frame of shape {frame.shape} after frames of {first.shape}")
        batch.append(frame)
        if len(batch) == size[0]:
            array.append(np.stack(batch).astype(first.dtype, copy=False), axis=0)
            batch = []
    if batch:
        array.append(np.stack(batch).astype(first.dtype, copy=False), axis=0)
    return array
