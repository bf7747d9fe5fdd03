"""The quasi-optimal row filter: O(width) work per row (method page *Row filters*, §2.3,
generalised)."""

from __future__ import annotations

import os
from typing import Literal

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import check_memory, images, positive_int, real_array
from ..field.model import ARFieldModel
from .base import MIN_RATIO, RowFilter
from .wiener_bound import wiener_error_map

_MODES = ("ends", "exact", "toeplitz")
_ROW_MODELS = ("propagated", "nominal", "implied")

IMPLIED_RHO = 0.999
"""row_models="auto" takes "implied" for n_y ≥ 2 from this ρ_y on ..."""
IMPLIED_RATIO = 0.1
"""... at noise ratios σ_θ²/σ_x² up to this one (class docstring)."""


def check_row_models(row_models: str, auto: bool = False) -> None:
    """ValueError unless `row_models` names a source of the row models (or, with `auto`,
    is "auto")."""
    choices = ("auto", *_ROW_MODELS) if auto else _ROW_MODELS
    if row_models not in choices:
        names = ", ".join(repr(c) for c in choices[:-1])
        raise ValueError(f"row_models must be {names} or {choices[-1]!r}, got {row_models!r}")


def auto_row_models(model: ARFieldModel, ratio: float) -> str:
    """The row models of row_models="auto" for `model` at σ_θ²/σ_x² = `ratio`: "implied"
    near a unit root at high SNR (n_y ≥ 2, ρ_y ≥ IMPLIED_RHO, ratio ≤ IMPLIED_RATIO), where
    the plan's models lose up to +19 % causal / +95 % smoothed (≤ 0.4 % outside it);
    "propagated" elsewhere."""
    near_unit_root = model.order[0] >= 2 and model.rho[0] >= IMPLIED_RHO
    return "implied" if near_unit_root and ratio <= IMPLIED_RATIO else "propagated"


_MIN_ROW_MODELS = 16
"""The fewest row models a plan may fit however wide the row (``MIN_ROW_MODELS`` of
``scalar_row_filter.rs``): what `_check_memory` must find room for."""


class ScalarRowFilter(RowFilter):
    """Quasi-optimal Kalman filter of z = x + θ row by row, O(W) work per row.

    The optimal row update is replaced by a filter and smoother along the row with a block
    AR(m) model of the prediction error of the whole state, fitted to the optimal filter's:
    one banded solve per row. Within +0.34 % of :class:`VectorRowFilter`'s MSE, and
    smoothed within +0.65 % of :func:`wiener_bound`, on the 72 cases of the benchmark grid.

    Parameters
    ----------
    model : ARFieldModel
        2-axis field model of x (axis 0 = rows), row multiplicity n_y ≤ 4.
    noise_var : float
        Variance σ_θ² of the white observation noise θ.
    width : int
        Row length W of the images.
    ar_order : int, optional
        Order m of the block AR model along the row, 1..8 (default: 8 for n_y = 1,
        max(n_x, 2) otherwise). ``ar_order=1`` with a (1,1) model is the source's scheme.
    smooth : bool, default False
        Add the RTS smoothing pass over the rows.
    mean : float, default 0.0
        The field's mean (subtracted before filtering, added back).
    threads : int, optional
        Threads for the frames of a stack and the weighted rows (None: all cores).
    modes : {"ends", "exact", "toeplitz"}, default "ends"
        Where the band of the optimal prediction covariance comes from: "exact", the
        eigenbasis of the whole row (O(W³) once); "ends", the same band with the row's
        interior taken from the infinite row (O(W'³) once, W' of a few hundred; outputs
        within ~1e-10 of "exact"); "toeplitz", the infinite row's alone (no eigenbasis; a
        little worse near the row's ends).
    row_models : {"auto", "propagated", "nominal", "implied"}, default "auto"
        Where the row models of images with missing pixels or per-pixel noise come from:
        "propagated", refitted row by row to the weighted systems; "nominal", the plan's
        (fast, unfit at high SNR); "implied", propagated on every image. "auto" takes
        "implied" for n_y ≥ 2, ρ_y ≥ 0.999 and σ_θ²/σ_x² ≤ 0.1, "propagated" otherwise.

    Raises
    ------
    TypeError
        `model` is not an ARFieldModel.
    ValueError
        A model without two axes or with n_y > 4, a bad option, a noise ratio σ_θ²/σ_x²
        outside float64's normal range, or one too small for the start rows (n_y ≥ 3 at
        σ_θ² ≲ 1e-16 σ_x²; :class:`VectorRowFilter` handles it).
    MemoryError
        Rows too wide to plan on this machine.

    See Also
    --------
    VectorRowFilter : The optimal filter, O(W²) per row.
    denoise : Model and noise estimated from the image.

    Notes
    -----
    The per-row models are built on the first call for an image height and cached. NaN
    pixels are missing observations and a per-pixel noise map may be given to
    :meth:`filter`. The method (§2.3, generalised) is on :doc:`/methods/row_filters`; the
    losses, speeds and limits on :doc:`/benchmarks/row_filters` and :doc:`/accuracy`; why
    it is built so in :doc:`/design/row_filter_numerics`. Filters pickle (they hold no
    per-image state).

    References
    ----------
    .. [1] O. V. Popov, dissertation, Ulyanovsk, 2000, eqs. 3.8–3.17, 3.34–3.36 ([P] in
       :doc:`/references`).

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    >>> x = model.sample((128, 128), seed=1)
    >>> z = x + np.random.default_rng(0).normal(0, 1, x.shape)
    >>> filt = kf.ScalarRowFilter(model, noise_var=1.0, width=128, smooth=True)
    >>> x_hat = filt.filter(z)
    >>> bool(np.mean((x_hat - x) ** 2) < 0.1 * np.mean((z - x) ** 2))
    True
    """

    __slots__ = ("_ar_order", "_modes", "_row_models")

    def __init__(
        self,
        model: ARFieldModel,
        noise_var: float,
        width: int,
        ar_order: int | None = None,
        smooth: bool = False,
        *,
        mean: float = 0.0,
        threads: int | None = None,
        modes: Literal["ends", "exact", "toeplitz"] = "ends",
        row_models: Literal["auto", "propagated", "nominal", "implied"] = "auto",
    ) -> None:
        unit, ratio = self._set_parameters(model, noise_var, width, smooth, mean, threads)
        check_row_models(row_models, auto=True)
        chosen = auto_row_models(self._model, ratio) if row_models == "auto" else row_models
        self._ar_order = None if ar_order is None else positive_int(ar_order, "ar_order")
        if modes not in _MODES:
            raise ValueError(f"modes must be 'ends', 'exact' or 'toeplitz', got {modes!r}")
        self._modes = modes
        self._row_models = chosen
        self._check_memory()
        self._core = _core.ScalarRowFilter(unit, ratio, self._width, self._ar_order, modes, chosen)

    def _check_memory(self) -> None:
        """MemoryError for rows too wide to plan: a row system's band (W n_y (b + 1) doubles)
        held as precision, factor and substitution tables (~5 bands) for each row model of
        the plan (the kernel fits up to 64 within 1 GiB, at least 16 however wide the row:
        its ``MIN_ROW_MODELS``) and the start's, and with modes="exact" the row's W × W
        eigenbasis."""
        n_y = self._model.order[0]
        m = min(self.ar_order, 8)  # larger orders are refused by the kernel (ValueError)
        band = self._width * n_y * (n_y * (m + 1))
        check_memory((band,), np.dtype(np.float64), copies=5 * _MIN_ROW_MODELS + 6)
        if self._modes == "exact":
            check_memory((self._width, self._width), np.dtype(np.float64), copies=3)

    @property
    def modes(self) -> str:
        """Where the band of P_e comes from: "ends", "exact" or "toeplitz"."""
        return self._modes

    @property
    def row_models(self) -> str:
        """The row models: "propagated", "nominal" or "implied" (what "auto" chose)."""
        return self._row_models

    @property
    def ends_span(self) -> int | None:
        """The span W' of the exact ends when modes="ends" split the row.

        None when the row is not split: the band comes from the whole row's eigenbasis or
        from the Fourier modes alone.
        """
        return self._core.ends_span()

    def filter(
        self,
        z: npt.ArrayLike,
        noise_var: npt.ArrayLike | None = None,
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
            released), with a channel axis if `channel_axis` is given; NaN pixels are
            missing observations.
        noise_var : array_like, optional
            Per-pixel σ_θ² map broadcastable to z's shape (to one channel's with
            `channel_axis`; > 0; inf = missing); None = the filter's `noise_var` everywhere.
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
            Images of the wrong width or dimension, infinite pixels, pixels with
            ``abs(z - mean) > 2**1000``, a bad noise map, an estimate that overflows float64
            (pixels far from the mean at a tiny noise ratio), a bad `out`, `out` with
            `channel_axis`.
        MemoryError
            The row models a smoothed weighted pass keeps would not fit.
        """
        return self._per_channel(
            z, channel_axis, mask, out, lambda a, o: self._filter_one(a, noise_var, o)
        )

    def _filter_one(
        self, z: npt.ArrayLike, noise_var: npt.ArrayLike | None, out: np.ndarray | None
    ) -> np.ndarray:
        """:meth:`filter` of grey images or a stack."""
        if noise_var is None:
            # the kernel checks every pixel in its own pass over the row: no pass here
            # unless it finds a NaN (then a missing pixel) or infinite one (refused below)
            try:
                arr = images(z, self._width, finite=False)
                if self._row_models == "implied":
                    self._check_models_memory(arr.shape)
                return self._filter_checked(arr, out=out)
            except _core.NonFiniteError:
                pass
        arr = images(z, self._width, missing=True)
        missing = np.isnan(arr)
        if noise_var is None and not missing.any():
            return self._filter_checked(arr, out=out)
        self._check_models_memory(arr.shape)
        weights = self._weights(arr.shape, noise_var)
        weights[missing] = 0.0  # the kernel ignores the (NaN) value of a weight-0 pixel
        return self._filter_checked(arr, weights, out)

    def _check_models_memory(self, shape: tuple[int, ...]) -> None:
        """MemoryError when the propagated row models that a smoothed pass keeps for weighted
        images (one band of W n_y (b + 1) doubles per row, for each frame filtered at once)
        would not fit; the causal pass makes them as it reaches the rows and the nominal ones
        are the plan's, so neither keeps anything per row."""
        if self._row_models == "nominal" or not self._smooth:
            return
        n_y = self._model.order[0]
        band = self._width * n_y * (n_y * (min(self.ar_order, 8) + 1))
        frames = shape[0] if len(shape) == 3 else 1
        at_once = min(frames, self._threads or os.cpu_count() or 1)
        check_memory((shape[-2], band), np.dtype(np.float64), copies=max(at_once, 1))

    def _weights(self, shape: tuple[int, ...], noise_var: npt.ArrayLike | None) -> np.ndarray:
        """σ_x²/σ_θ² per pixel (the kernel works in units of σ_x), C-contiguous of `shape`."""
        sigma = self._model.sigma
        if noise_var is None:
            return np.full(shape, 1.0 / (self._noise_var / sigma / sigma))
        var = real_array(noise_var, "noise_var")
        try:
            var = np.broadcast_to(var, shape)
        except ValueError:
            raise ValueError(
                f"noise_var of shape {var.shape} does not broadcast to the images' {shape}"
            ) from None
        if np.isnan(var).any() or not (var > 0).all():
            raise ValueError("noise_var must be > 0 at every pixel (inf marks a missing one)")
        with np.errstate(divide="ignore", over="ignore", under="ignore"):
            ratio = var / sigma / sigma
            if ratio.size and ratio.min() < MIN_RATIO:
                raise ValueError(
                    f"noise_var / sigma² must be at least {MIN_RATIO:g} at every pixel "
                    f"(float64's normal range), got {ratio.min():g}"
                )
            return np.ascontiguousarray(1.0 / ratio)

    def error_variance(self, height: int, noise_var: npt.ArrayLike | None = None) -> np.ndarray:
        """Per-pixel error variance map of this filter's estimate.

        Parameters
        ----------
        height : int
            Image height H.
        noise_var : array_like, optional
            The per-pixel σ_θ² map the image will be filtered with (as in :meth:`filter`;
            for an image z with NaN pixels, ``np.where(np.isnan(z), np.inf,
            filt.noise_var)``). None: the nominal `noise_var` everywhere.

        Returns
        -------
        numpy.ndarray
            The (H, W) map.

        Raises
        ------
        ValueError
            A bad noise map, or a noise map with ``smooth=True``.
        MemoryError
            A map larger than the machine's memory.

        Notes
        -----
        Causal: the variance the filter itself assumes, from the band of each row system's
        inverse by selected inversion, O(W n_y b²) per row system; exact on rows 1..n_y and
        within a few per cent of the optimal filter's map after them, mostly on the safe
        side. Smoothed: the optimal smoother's map, :func:`wiener_error_map`, which the
        smoothed filter's MSE exceeds by its gap to the bound (≤ +0.65 % on the
        benchmark grid). See :doc:`/methods/row_filters`, §2.3.
        """
        height = positive_int(height, "height")
        check_memory((height, self._width), np.dtype(np.float64))
        if self._smooth:
            if noise_var is not None:
                raise ValueError(
                    "the smoothed error map (wiener_error_map) assumes one noise variance: "
                    "per-pixel noise_var maps are supported with smooth=False only"
                )
            return wiener_error_map(self._model, self._noise_var, (height, self._width))
        if noise_var is None:  # (row_models="implied": the kernel propagates nominal weights)
            return self._in_image_units(self._core.error_variance(height))
        weights = self._weights((height, self._width), noise_var)
        return self._in_image_units(self._core.error_variance(height, weights))

    @property
    def ar_order(self) -> int:
        """The order m of the block AR model along the row.

        The default is 8 for n_y = 1 and max(n_x, 2) otherwise.
        """
        if self._ar_order is not None:
            return self._ar_order
        return _core.default_ar_order(*self._model.order)

    def __repr__(self) -> str:
        return (
            f"ScalarRowFilter({self._model!r}, noise_var={self._noise_var}, "
            f"width={self._width}, ar_order={self.ar_order}, smooth={self._smooth}, "
            f"modes={self._modes!r}, row_models={self._row_models!r})"
        )

    def __reduce__(self):
        kwargs = {
            "mean": self._mean,
            "threads": self._threads,
            "modes": self._modes,
            "row_models": self._row_models,
        }
        args = (self._model, self._noise_var, self._width, self._ar_order, self._smooth)
        return (_rebuild, (args, kwargs))


def _rebuild(args, kwargs) -> ScalarRowFilter:
    return ScalarRowFilter(*args, **kwargs)
