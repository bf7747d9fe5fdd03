"""Colour channels as scikit-image's ``channel_axis`` treats them: each channel a grey image
of its own, and a warning for the (H, W, 3) array that would otherwise be read as a stack."""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np


def check_channel_axis(channel_axis: object, ndim: int) -> int | None:
    """`channel_axis` as a non-negative axis of an `ndim`-D array, or None."""
    if channel_axis is None:
        return None
    if isinstance(channel_axis, bool) or not isinstance(channel_axis, (int, np.integer)):
        raise TypeError(f"channel_axis must be an integer or None, got {channel_axis!r}")
    if not -ndim <= channel_axis < ndim:
        raise ValueError(f"channel_axis {channel_axis} is out of range for a {ndim}-D array")
    return int(channel_axis) % ndim


def warn_if_colour(arr: np.ndarray, caller: str, stack_ndim: int = 3) -> None:
    """A UserWarning when a `stack_ndim`-D array ends in an axis of 3 or 4 values and no
    `channel_axis` was given: an RGB(A) image read as a stack of 3- or 4-pixel-wide frames."""
    if arr.ndim == stack_ndim and arr.shape[-1] in (3, 4) and arr.shape[-2] > 4:
        warnings.warn(
            f"{caller} got an array of shape {arr.shape}, read as a stack of "
            f"{arr.shape[0]} frames {arr.shape[-1]} pixels wide; if it is a colour image, "
            "pass channel_axis=-1 (each channel is then filtered as an image of its own)",
            UserWarning,
            stacklevel=3,
        )


def per_channel(
    arr: np.ndarray, channel_axis: int, apply: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """`apply` run on each channel (C-contiguous, the channel axis removed), the results
    stacked back along `channel_axis`."""
    channels = [np.ascontiguousarray(c) for c in np.moveaxis(arr, channel_axis, 0)]
    return np.stack([apply(c) for c in channels], axis=channel_axis)
