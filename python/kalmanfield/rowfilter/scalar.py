"""The quasi-optimal row filter: O(width) work per row (SPEC §2.3, generalised)."""

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
    """Quasi-optimal Kalman filter of z = x + θ row by row (SPEC §2.3), for every
    multiplicity (n_y, n_x) ≤ 4, within ~2 % of :class:`VectorRowFilter` (see the README's
    loss table).

    SPEC §2.3 replaces the optimal row update — a Wiener estimate of the prediction error
    from the innovation — by a filter + smoother along the row with an AR model of the
    prediction error fitted to the optimal filter's P_e (with the γ_{ℓ+1} fix). The source's
    version models only the current row's error with an AR(1) and loses 21–35 % for (2,2);
    here the modelled vector is the prediction error of all n_y rows of the state (so older
    rows are corrected too), it follows a block AR(m) along the row with m = `ar_order`,
    and the filter + smoother along the row becomes one banded SPD solve of half-bandwidth
    n_y(m+1) − 1: O(W n_y² m) per row. Default m: max(n_x, 2) (at most 8) for n_y ≥ 2
    (within 0.4 % of m = n_x + 1 with a narrower band); 8 for n_y = 1, where nothing else in
    the state absorbs the model's misfit and the loss grows as ρ → 1 ((1, 1) at ρ = 0.99,
    σ_x²/σ_θ² = 3: +10.7 % with m = 2, +1.4 % with m = 8; m = 8 is never worse on the
    README's grids, and the band b = 8 costs 1.6× the time of m = 2, 4× with weighted rows).
    m = 1 is the source's scheme for (1, 1): up to +4.2 % on the issue's grid.
    The model follows the optimal P_e,k down the rows: refitted whenever the band has drifted
    from the one it was fitted to by more than 0.1 % of the band of P_e − Q (the part that
    changes from row to row), and frozen once the band has settled (the geometric tail of
    its row-to-row changes below 0.1 % on that scale; at most 64 models, down to 16 for
    rows whose models would take over 1 GiB, then the last one serves); rows 1..n_y use the
    exact stationary prior. For n_y ≥ 3 at σ_θ² ≲ 1e-16 σ_x² their systems
    Λ + Σ h hᵀ/σ_θ² (h dense rows of the whitening's L) do not factor in float64: a
    ValueError at construction (:class:`VectorRowFilter` handles such noise).

    At high SNR (σ_x²/σ_θ² ≥ 100, beyond the issue's grid) with ρ ≥ 0.95 the default band
    of n_y = 2 loses more (up to +2.9 % causal, +5.3 % smoothed for (2, 2) at ρ = 0.99;
    README, "High SNR"); ar_order = max(n_x, 2) + 2 cuts that to +1.5 % / +2.9 %.

    ar_order=1 with a (1, 1) model is the source's scheme [P 3.11–3.17].
    smooth=True adds the RTS pass over the rows (the default of :func:`denoise`): within
    ~2 % of :func:`wiener_bound`.
    mean : the field's mean (subtracted before filtering, added back).
    modes : where the band of the optimal P_e comes from. "exact": the eigenbasis of the row
        correlation, edges of the row included (O(W³) once, faer: 1.4 s at W = 2048, 11.5 s
        at 4096). "ends" (default): the same band, spliced — the first and last W'/2
        columns from the eigenbasis of a row of W' points, the columns in between from the
        Fourier modes of the infinite row (the row's far end reaches a column only through
        terms that decay with the distance). W' (:attr:`ends_span`) is the smallest power
        of two ≥ 256 whose band 3W'/8 from its ends agrees with the infinite row's within
        1e-11 (relative) plus 8× their rounding floor on every row of the plan; rows
        narrower than 2W' use the whole row's eigenbasis, bit for bit as "exact", and so do
        the few (4,4) models at ρ ≥ 0.95 whose band noise hides the splice. O(W'³)
        once: 0.01–0.3 s at any width (W' = 256–1024 for ρ_x ≤ 0.95). Outputs agree with
        "exact" to ≤ 1e-10 (n_y ≤ 2) and ~5e-10 (n_y = 3); for n_y = 4 at ρ ≥ 0.9 the band
        itself is only computable to ~1e-9 and the outputs differ by up to ~2e-4 (the README
        has the table and the reason).
        "toeplitz": the Fourier modes alone (the band is then the same at every column; no
        eigenbasis at all; it ignores the larger error near the row's ends — the README
        gives the loss).
    The per-row models are built on the first call for a given image height and cached.
    With smooth=True the RTS pass needs nothing of the forward pass but the filtered rows
    h · ŷ_t (written to the output) and the state after the start rows: no store of the
    filtered states, so the working memory is a few rows whatever the height.

    Missing pixels and per-pixel noise: :meth:`filter` takes NaN pixels as missing
    observations and an optional per-pixel noise variance map. They enter the row update
    (A_t = Λ_t + Σ_ℓ h hᵀ/σ²_θ,tℓ, refactored per row) and the row models: below a missing
    or much noisier pixel the prediction error is far larger than the nominal model's, so
    from the first row whose weights depart from `noise_var` (a map equal to it is the
    plain filter) every row's Λ_t is refitted to the prediction covariance the filter implies,
    S A_{t−1}⁻¹ Sᵀ + Q (band of A_{t−1}⁻¹ by selected inversion, the same block AR fit per
    column), and both passes use it. Measured against the exact posterior mean (16², ρ = 0.9,
    mean of 6 samples, smoothed): 10 % missing at σ_x²/σ_θ² = 1e4: (1,1) 1.03×, (2,1),
    (2,2), (4,1), (4,4) ≤ 1.00×, at 1e10 (4,1) 1.00×; per-pixel σ_θ² log-uniform over
    100× either way at σ_x²/σ_θ² = 100: (2,1), (4,1) 1.00× (the nominal models gave 2–1e4×
    there, up to divergence). Cost: O(W n_y b²) for the inversion and O(W (m n_y)³) for
    the fits per row; the causal pass makes each row's model as it reaches the row, the
    smoothed one keeps a row model (W n_y (b + 1) doubles) per row of the image for the RTS
    pass. row_models="nominal" keeps the plan's models instead (the fast path of
    :func:`denoise`; unfit at high SNR: 10 % missing at σ_x²/σ_θ² = 1e4 gave (1,1) ~6×,
    (2,1) ~5e4×, (4,1) ~4× the posterior's MSE, smoothed; within 6 % at ≤ 100 with
    scattered missing pixels, but not with whole missing rows: the first row missing of a
    16² (1,1) image at ρ_y = 0.99 gave 66 σ² at σ_x²/σ_θ² = 100 and 2.8 σ² at 1, smoothed;
    the propagated models 0.005 σ²).

    row_models="implied" propagates the models from the first predicted row on for every
    image, the nominal ones too (each Λ_t fitted to S A_{t−1}⁻¹ Sᵀ + Q, the covariance the
    filter itself implies, so the RTS pass pairs consistent models). Near a unit root at
    high SNR the plan's models, fitted to the optimal filter's P_e,t, compound their misfit
    down the rows: exact MSEs on 32² at σ_θ²/σ_x² = 0.01, ρ_x = 0.9, causal against
    :class:`VectorRowFilter` / smoothed against :func:`wiener_bound`: (2,2) at ρ_y = 0.9999
    +1.2 % / +5.1 % with the plan's models ("propagated"), +0.00 % / +0.00 % implied;
    (3,3) at ρ_y = 0.9997 +1.1 % / +5.4 %, implied +0.00 % / +0.00 %; (2,2) at ρ = 0.99979
    on both axes, 21 × 4, +19 % / +95 %, implied +0.00 %. Over 45 cases (24², n_y = 2–4,
    ρ_y = 0.99–0.9999) never more than 0.07 % worse than the plan's models. Cost: the
    propagated rows' (above) on every image, 14–113× the plan's time. row_models="auto"
    (default) takes it for n_y ≥ 2, ρ_y ≥ 0.999 and σ_θ²/σ_x² ≤ 0.1 (the plan's models
    lost up to +19 % causal, +95 % smoothed there; ≤ 0.4 % at ρ_y ≤ 0.998 or σ_θ²/σ_x² = 1,
    24², ρ_x = 0.5–0.99) and "propagated" otherwise; :attr:`row_models` tells which.
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
        """ "ends", "exact" or "toeplitz" (see the class docstring)."""
        return self._modes

    @property
    def row_models(self) -> str:
        """ "propagated", "nominal" or "implied" (what "auto" chose): where the row models
        come from (class docstring)."""
        return self._row_models

    @property
    def ends_span(self) -> int | None:
        """W' of the exact ends when modes="ends" split the row (None: not split, the band
        comes from the whole row's eigenbasis or from the Fourier modes alone)."""
        return self._core.ends_span()

    def filter(
        self,
        z: npt.ArrayLike,
        noise_var: npt.ArrayLike | None = None,
        *,
        out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Estimate x from z: one image (H, W) or a stack (F, H, W) (frames in parallel, GIL
        released). NaN pixels are missing observations. `noise_var`: per-pixel σ_θ² map
        broadcastable to z's shape (> 0; inf = missing); None = the filter's noise_var.
        Pixels with |z − mean| > 2**1000 ≈ 1e301 are refused (ValueError), and so is an
        estimate that overflows float64 (|z − mean|·σ_x²/σ_θ² too large: pixels far from the
        mean at a tiny noise ratio; the vector filter copes). Returns float64 of z's shape,
        or `out` filled with it (a float64 C-contiguous array of z's shape that shares no
        memory with z: a buffer reused over a stream of frames)."""
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
        """(height, W) map of the per-pixel error variance of this filter's estimate.

        Causal (smooth=False): the variance the filter itself assumes, h_tᵀ [A_t⁻¹]_ℓℓ h_t per
        pixel (A_t = Λ_t + HᵀR⁻¹H, the row system it solves; [·]_ℓℓ the column's n_y × n_y
        block, read from the band of A_t⁻¹ by selected inversion in Rust: O(W n_y b²) per
        distinct A_t, none of the O(W³) of :class:`VectorRowFilter`). It is the optimal
        filter's error variance on rows 1..n_y, where Λ is the stationary prior's, and after
        them a band fit of the optimal one: on the README's 60-case grid (24², ρ ≤ 0.95) within
        6.0 % of :meth:`VectorRowFilter.error_variance` pixel by pixel, and the filter's
        exact MSE within −2.7 %…+0.13 % of it (mostly below: the map errs on the safe side).

        noise_var: the per-pixel σ_θ² map the image will be filtered with (as in
        :meth:`filter`: broadcastable to (height, W), > 0, inf = missing pixel; for an image
        z with NaN pixels, ``np.where(np.isnan(z), np.inf, self.noise_var)``); the map is then
        that of the weighted systems the filter solves, one selected inversion per row (row
        after row with the propagated row models, which it makes as :meth:`filter` does but
        drops row by row, so the map needs no memory beyond itself and the weights; in
        parallel with row_models="nominal"). None: the nominal noise_var everywhere.

        smooth=True: the smoothed covariance of this filter's model is not banded, so the map
        returned is the optimal smoother's, :func:`wiener_error_map` (O(H³ + W³)), which the
        smoothed filter's true MSE lies above by its gap to the Wiener bound (≤ +0.65 % in the
        mean on the README's grid); it has no per-pixel noise variant (ValueError).
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
        """Order m of the block AR model along the row (the default: 8 for n_y = 1,
        max(n_x, 2) otherwise; see the class docstring)."""
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
