"""Frame-wise work on dask arrays of frames: the row filters, denoise and segment, one task
per chunk of whole frames."""

from __future__ import annotations

import builtins
from typing import Any

import numpy as np
import pandas as pd

from ..denoising import denoise as _denoise
from ..identification import model_from_noisy
from ..io._optional import optional
from ..rowfilter.base import RowFilter
from ..tracking import segment as _segment
from ..tracking.segment import COLUMNS, otsu_from_histogram
from ._dask import as_frames, chunk_starts, dask_array


def filter(frames: Any, row_filter: RowFilter) -> Any:
    """Filter every frame of a dask array with a row filter, one task per chunk of frames.

    Parameters
    ----------
    frames : dask.array.Array or array_like
        A stack (F, H, W) of width ``row_filter.width``; chunks along the frames (chunks
        across a frame are merged).
    row_filter : ScalarRowFilter or VectorRowFilter
        The filter (it pickles, so it travels to the workers).

    Returns
    -------
    dask.array.Array
        The estimates, float64, lazily; equal to ``row_filter.filter(frames)`` bit for bit.

    Raises
    ------
    TypeError
        `row_filter` is not a row filter, or the frames are not real numbers.
    ValueError
        Frames that are not a 3-D stack.
    ImportError
        dask is not installed (the ``dask`` extra).

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> import kalmanfield.dask as kfd
    >>> model = kf.ARFieldModel([0.9, 0.9], [1, 1])
    >>> z = np.random.default_rng(0).normal(size=(6, 32, 32))
    >>> fast = kf.ScalarRowFilter(model, 1.0, 32)
    >>> out = kfd.filter(z, fast)
    >>> bool(np.array_equal(out.compute(), fast.filter(z)))
    True
    """
    if not isinstance(row_filter, RowFilter):
        raise TypeError(
            f"row_filter must be a ScalarRowFilter or a VectorRowFilter, got {row_filter!r}"
        )
    arr = as_frames(frames)
    return arr.map_blocks(_filter_block, row_filter, dtype=np.float64)


def _filter_block(block: np.ndarray, row_filter: RowFilter) -> np.ndarray:
    return row_filter.filter(block)


def denoise(
    frames: Any,
    *,
    model: Any = None,
    noise_var: float | None = None,
    sigma: float | None = None,
    mean: float | None = None,
    method: str = "stationary",
    fit_frame: int = 0,
    **kwargs: Any,
) -> Any:
    """Denoise every frame of a dask array, the model and the noise level found once.

    Parameters
    ----------
    frames : dask.array.Array or array_like
        A stack (F, H, W); chunks along the frames (chunks across a frame are merged).
    model : ARFieldModel, optional
        The field model (stationary and vector filters). Default: fitted once, by
        :func:`~kalmanfield.model_from_noisy`, to frame `fit_frame`.
    noise_var : float, optional
        The noise variance σ_θ². Give it or `sigma`; neither: estimated once from frame
        `fit_frame` (with the model when it is fitted, by
        :func:`~kalmanfield.estimate_noise_var` otherwise).
    sigma : float, optional
        The noise standard deviation σ_θ.
    mean : float, optional
        The field mean of the stationary filter; default the fitted mean, or the mean of
        frame `fit_frame` when `model` is given.
    method : {"stationary", "adaptive", "vector"}, default "stationary"
        The filter, as for :func:`~kalmanfield.denoise`. ``"auto"`` is refused: its choice is
        made per image, so chunks could choose differently.
    fit_frame : int, default 0
        The frame the model, the noise level and the mean are found from.
    **kwargs
        Any other argument of :func:`~kalmanfield.denoise` (``smooth``, ``window``…).

    Returns
    -------
    dask.array.Array
        The estimates, lazily: chunk by chunk, equal bit for bit to
        ``kf.denoise(frames, model=…, noise_var=…, mean=…, method=…)`` in memory with the
        same model, noise level and mean.

    Raises
    ------
    ValueError
        ``method="auto"``, both `noise_var` and `sigma`, a `fit_frame` out of range, or
        what :func:`~kalmanfield.denoise` refuses.
    ImportError
        dask is not installed (the ``dask`` extra).

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> import kalmanfield.dask as kfd
    >>> x = kf.ARFieldModel([0.9, 0.9, 0.9], [1, 2, 2]).sample((8, 64, 64), seed=1)
    >>> z = x + np.random.default_rng(0).normal(0, 0.5, x.shape)
    >>> clean = kfd.denoise(z, sigma=0.5).compute()
    >>> bool(np.mean((clean - x) ** 2) < 0.5 * 0.25)
    True
    """
    if method == "auto":
        raise ValueError(
            "method='auto' chooses per image, so chunks could choose differently: "
            "give method='stationary', 'adaptive' or 'vector'"
        )
    if noise_var is not None and sigma is not None:
        raise ValueError("give noise_var or sigma, not both")
    nv = sigma**2 if sigma is not None else noise_var
    arr = as_frames(frames)
    if not 0 <= fit_frame < arr.shape[0]:
        raise ValueError(f"fit_frame must lie in 0..{arr.shape[0] - 1}, got {fit_frame}")
    if method == "adaptive":
        if model is not None:
            raise ValueError("the adaptive filter takes no model (method='stationary' does)")
        if nv is None:
            from ..denoising import estimate_noise_var

            nv = estimate_noise_var(np.asarray(arr[fit_frame].compute()))
    elif model is None or nv is None or mean is None:
        first = np.asarray(arr[fit_frame].compute(), dtype=np.float64)
        if model is None:
            fitted, fitted_mean, fitted_nv = model_from_noisy(first)
            model = fitted
            mean = fitted_mean if mean is None else mean
            nv = fitted_nv if nv is None else nv
        else:
            mean = float(np.nanmean(first)) if mean is None else mean
            if nv is None:
                from ..denoising import estimate_noise_var

                nv = estimate_noise_var(first)
    settings = dict(model=model, noise_var=nv, mean=mean, method=method, **kwargs)
    return arr.map_blocks(_denoise_block, settings, dtype=np.float64)


def _denoise_block(block: np.ndarray, settings: dict[str, Any]) -> np.ndarray:
    if settings["method"] == "adaptive":
        settings = {k: v for k, v in settings.items() if k not in ("model", "mean")}
    return np.asarray(_denoise(block, **settings), dtype=np.float64)


def segment(frames: Any, threshold: Any, **kwargs: Any) -> Any:
    """Segment every frame of a dask array: a dask DataFrame of spots with a ``frame`` column.

    Parameters
    ----------
    frames : dask.array.Array or array_like
        A stack (F, H, W); chunks along the frames (chunks across a frame are merged).
    threshold : float or "otsu"
        The threshold of :func:`~kalmanfield.segment`; ``"otsu"`` is Otsu's threshold of the
        whole stack (one pass over it for the histogram), as in memory. A callable is
        refused (it would see one chunk).
    **kwargs
        ``min_area`` and ``connectivity`` of :func:`~kalmanfield.segment`.

    Returns
    -------
    dask.dataframe.DataFrame
        One partition per chunk, the columns of :func:`~kalmanfield.segment` with
        ``frame`` first (the frame's index in the stack); computed, equal to
        ``kf.segment(frames, threshold, frame_no=0)`` in memory (the index aside).

    Raises
    ------
    ValueError
        A callable threshold or one :func:`~kalmanfield.segment` refuses.
    ImportError
        dask is not installed (the ``dask`` extra).

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield.dask as kfd
    >>> frames = np.zeros((4, 32, 32))
    >>> frames[:, 5:8, 10:13] = 1.0
    >>> spots = kfd.segment(frames, 0.5).compute()
    >>> spots[["frame", "x", "y"]].to_numpy().tolist()[:2]
    [[0.0, 11.0, 6.0], [1.0, 11.0, 6.0]]
    """
    dd = optional("dask.dataframe", "kalmanfield.dask.segment")
    delayed = optional("dask", "kalmanfield.dask.segment").delayed
    arr = as_frames(frames)
    if callable(threshold):
        raise ValueError("a callable threshold would see one chunk: compute the number first")
    if isinstance(threshold, str):
        if threshold != "otsu":
            raise ValueError(f"threshold must be a number or 'otsu', got {threshold!r}")
        threshold = _stack_otsu(arr)
    extra = set(kwargs) - {"min_area", "connectivity"}
    if extra:
        raise TypeError(f"segment() got unexpected keyword arguments {sorted(extra)}")
    _segment(np.zeros((1, 1)), threshold, **kwargs)  # the settings' errors, here and now
    blocks = arr.to_delayed().ravel()
    starts = chunk_starts(arr.chunks[0])
    parts = [
        delayed(_segment_block)(block, threshold, start, kwargs)
        for block, start in builtins.zip(blocks, starts)
    ]
    meta = pd.DataFrame({"frame": np.zeros(0, np.int64), **_empty_columns()})
    return dd.from_delayed(parts, meta=meta, verify_meta=False)


def _empty_columns() -> dict[str, np.ndarray]:
    table = _segment(np.zeros((1, 1)), 0.5)
    return {name: table[name].to_numpy()[:0] for name in COLUMNS}


def _segment_block(block: np.ndarray, threshold: float, start: int, kwargs: dict) -> pd.DataFrame:
    table = _segment(block, threshold, frame_no=start, **kwargs)
    return table


def _stack_otsu(arr: Any) -> float:
    """Otsu's threshold of the whole stack, as :func:`~kalmanfield.segment` computes it in
    memory: the same 256 bins over [min, max], counted chunk by chunk."""
    da = dask_array()
    low, high = da.compute(arr.min(), arr.max())
    low, high = float(low), float(high)
    if not (np.isfinite(low) and np.isfinite(high)):
        raise ValueError("Otsu's threshold needs finite pixels")
    if low == high:
        raise ValueError("Otsu's threshold of a constant stack is undefined: give a number")
    counts, edges = da.histogram(arr.astype(np.float64), bins=256, range=(low, high))
    return otsu_from_histogram(np.asarray(counts.compute()), np.asarray(edges))
