"""What the row filters (method page *Row filters*) share: argument checks and the common
Python front."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from .._channels import check_channel_axis, per_channel, warn_if_colour
from .._validation import (
    boolean_mask,
    images,
    positive_float,
    positive_int,
    real_array,
    real_number,
    thread_count,
)
from ..field.model import ARFieldModel

#: smallest σ_θ²/σ_x² the row filters accept: float64's smallest normal number
MIN_RATIO = float(np.finfo(np.float64).tiny)


def row_model(model: object) -> ARFieldModel:
    """A 2-axis ARFieldModel (axis 0 = rows) with n_y ≤ 4."""
    if not isinstance(model, ARFieldModel):
        raise TypeError(f"model must be a kalmanfield.ARFieldModel, got {type(model).__name__}")
    if model.ndim != 2:
        raise ValueError(f"row filters need a 2-axis model (rows, columns), got {model.ndim} axes")
    if model.order[0] > 4:
        raise ValueError(f"row filters support a row multiplicity up to 4, got {model.order[0]}")
    return model


def unit_scale(model: ARFieldModel, noise_var: float) -> tuple[ARFieldModel, float]:
    """`model` with σ_x = 1 and σ_θ²/σ_x²: what the row kernels are built with. Their
    estimates are linear and their gains depend on σ_θ²/σ_x² alone (variances scale by
    σ_x²), so working in units of σ_x keeps their products of variances inside float64
    whatever the images' scale (σ_x of 1e±100 overflowed them). ValueError when the ratio
    itself or its reciprocal is out of float64's normal range (a subnormal ratio, 1e-320,
    gave NaN images)."""
    sigma = model.sigma
    ratio = noise_var / sigma / sigma
    if not MIN_RATIO <= ratio <= 1.0 / MIN_RATIO:
        raise ValueError(
            f"noise_var / sigma² = {noise_var:g} / {sigma:g}² is out of float64's normal "
            f"range [{MIN_RATIO:g}, {1.0 / MIN_RATIO:g}]"
        )
    return (model if sigma == 1.0 else ARFieldModel(model.rho, model.order)), ratio


def in_image_units(variance: np.ndarray, sigma: float) -> np.ndarray:
    """A variance map in units of σ_x² (:func:`unit_scale`) turned, in place, into the
    images' units."""
    variance *= sigma
    variance *= sigma
    return variance


def output_array(out: object, arr: np.ndarray) -> np.ndarray:
    """`out` checked as the destination of a filter of the images `arr`, or a new array (None).
    A given `out` must be a writeable, C-contiguous float64 ndarray of the images' shape
    that shares no memory with them (the smoothing pass reads the images again after the
    forward pass has written its rows): a stream of frames can so reuse one buffer and skip
    the page faults of a fresh output (~5 ms per 2048² frame on the Intel VM of 2026-12-01).
    When the filter raises, what `out` holds is unspecified."""
    if out is None:
        return np.empty_like(arr)
    if not isinstance(out, np.ndarray):
        raise TypeError(f"out must be a NumPy array, got {type(out).__name__}")
    if out.dtype != np.float64:
        raise TypeError(f"out must be float64, got {out.dtype}")
    if out.shape != arr.shape:
        raise ValueError(f"out has shape {out.shape}, the images {arr.shape}")
    if not out.flags.c_contiguous or not out.flags.writeable:
        raise ValueError("out must be C-contiguous and writeable")
    if np.may_share_memory(out, arr):
        raise ValueError("out shares memory with the images: the filter reads them after writing")
    return out


class RowFilter:
    """Common front of :class:`VectorRowFilter` and :class:`ScalarRowFilter`: the checked
    parameters, their properties and :meth:`filter`. Subclasses set ``_core``."""

    __slots__ = ("_model", "_noise_var", "_width", "_smooth", "_mean", "_threads", "_core")
    _core: Any  # the subclass's kernel object (`_core.VectorRowFilter` or `ScalarRowFilter`)

    def _set_parameters(self, model, noise_var, width, smooth, mean, threads) -> tuple[Any, float]:
        """Checks and stores the parameters; returns the kernel's model and noise variance,
        in units of σ_x (:func:`unit_scale`)."""
        self._model = row_model(model)
        self._noise_var = positive_float(noise_var, "noise_var")
        self._width = positive_int(width, "width")
        self._smooth = bool(smooth)
        self._mean = real_number(mean, "mean")
        self._threads = thread_count(threads)
        unit, ratio = unit_scale(self._model, self._noise_var)
        return unit._core, ratio

    def _in_image_units(self, variance: np.ndarray) -> np.ndarray:
        """A kernel's variance map (units of σ_x²) in the images' units."""
        return in_image_units(variance, self._model.sigma)

    @property
    def model(self) -> ARFieldModel:
        """The field model."""
        return self._model

    @property
    def noise_var(self) -> float:
        """The observation noise variance σ_θ²."""
        return self._noise_var

    @property
    def width(self) -> int:
        """The row length W."""
        return self._width

    @property
    def smooth(self) -> bool:
        """Whether the RTS smoothing pass over the rows runs."""
        return self._smooth

    def filter(
        self,
        z: npt.ArrayLike,
        *,
        out: np.ndarray | None = None,
        channel_axis: int | None = None,
        mask: npt.ArrayLike | None = None,
    ) -> np.ndarray:
        """Estimate x from z, one image or a stack of frames.

        Parameters
        ----------
        z : array_like
            An image (H, W) or a stack (F, H, W) of width W (frames in parallel, GIL
            released), with a channel axis if `channel_axis` is given.
        out : numpy.ndarray, optional
            Destination: a writeable, C-contiguous float64 array of z's shape sharing no
            memory with z (a buffer reused over a stream of frames); not with `channel_axis`.
        channel_axis : int, optional
            The axis of colour channels: each channel is filtered as an image of its own.
        mask : array_like of bool, optional
            True = a missing pixel (as in ``numpy.ma``), of z's shape.

        Returns
        -------
        numpy.ndarray
            The estimate, float64 of z's shape (`out` when given).

        Raises
        ------
        ValueError
            Images of the wrong width or dimension, NaN or infinite pixels (masked ones too),
            pixels with ``abs(z - mean) > 2**1000``, a bad `out`, `out` with `channel_axis`.
        """
        return self._per_channel(
            z,
            channel_axis,
            mask,
            out,
            lambda a, o: self._filter_checked(images(a, self._width), out=o),
        )

    def _per_channel(
        self,
        z: npt.ArrayLike,
        channel_axis: int | None,
        mask: npt.ArrayLike | None,
        out: np.ndarray | None,
        run: Callable[[npt.ArrayLike, np.ndarray | None], np.ndarray],
    ) -> np.ndarray:
        """`run(images, out)` on z, NaN at the masked pixels, per channel if `channel_axis`
        (:mod:`kalmanfield._channels`)."""
        caller = f"{type(self).__name__}.filter"
        if channel_axis is None and mask is None:
            warn_if_colour(np.asarray(z), caller)
            return run(z, out)
        arr = real_array(z, "z")
        if mask is not None:
            arr = np.where(boolean_mask(mask, arr.shape, "z"), np.nan, arr)
        axis = check_channel_axis(channel_axis, arr.ndim)
        if axis is None:
            warn_if_colour(arr, caller)
            return run(arr, out)
        if out is not None:
            raise ValueError(
                "out= cannot be combined with channel_axis (a channel is not contiguous)"
            )
        return per_channel(arr, axis, lambda channel: run(channel, None))

    def _filter_checked(
        self,
        arr: np.ndarray,
        weights: np.ndarray | None = None,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """:meth:`filter` on images already checked by :func:`images`; `weights` (per-pixel
        1/σ_θ², ScalarRowFilter only) go to the kernel when given."""
        out = output_array(out, arr)
        if self._mean:
            arr = arr - self._mean
        extra = () if weights is None else (weights,)
        self._core.filter_into(arr, out, self._smooth, self._threads, *extra)
        if self._mean:
            out += self._mean
        return out
