"""The filter of frame sequences (method page *Sequence filter*, §2.5)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import (
    grid_shape,
    nonnegative_int,
    positive_float,
    real_array,
    real_number,
    thread_count,
)
from ..field.model import ARFieldModel
from ..rowfilter.base import in_image_units, unit_scale
from .error_model import MAX_FAST_ORDER, error_model

_METHODS = ("auto", "optimal", "fast")

#: method="auto" runs the exact filter on frames of at most this many rows and columns (its
#: transforms cost 4·H·W·(H + W) multiply-adds per frame), the fast filter on larger ones.
AUTO_OPTIMAL_SIDE = 128


def sequence_model(model: object) -> ARFieldModel:
    """A 3-axis ARFieldModel (t, y, x)."""
    if not isinstance(model, ARFieldModel):
        raise TypeError(f"model must be a kalmanfield.ARFieldModel, got {type(model).__name__}")
    if model.ndim != 3:
        raise ValueError(f"a sequence filter needs a 3-axis model (t, y, x), got {model.ndim} axes")
    return model


class SequenceFilter:
    """Kalman filter of a sequence of frames z_t = x_t + θ_t in space and time.

    x is a separable AR field with axes (t, y, x) and θ white noise. ``method="optimal"``
    is the exact Kalman filter over whole frames: in the eigenbasis of the frame covariance
    every spatial mode is an independent AR(n_t) sequence in time, so it runs H·W scalar
    filters, each started exactly from the stationary covariance (O(H·W·(H + W)) per
    frame). ``method="fast"`` predicts each frame from the previous estimates and filters
    the prediction error with the smoothed :class:`ScalarRowFilter` (O(H·W) per frame).

    Parameters
    ----------
    model : ARFieldModel
        3-axis field model of x, axes (t, y, x).
    noise_var : float
        Variance σ_θ² of the white observation noise θ.
    frame_shape : tuple of int
        (H, W) of the frames.
    method : {"auto", "optimal", "fast"}, default "auto"
        "auto": "optimal" when ``lag > 0``, n_t > 2 or both sides are at most 128, else
        "fast" (which supports n_t ≤ 2).
    lag : int, default 0
        Fixed-lag smoothing: each frame is estimated from the `lag` newer ones too
        ("optimal" only).
    mean : float, default 0.0
        The field's mean (subtracted before filtering, added back).
    threads : int, optional
        Threads across the frame (None: all cores).

    Raises
    ------
    ValueError
        A model without three axes, a non-positive `noise_var`, a bad `frame_shape`, a
        negative `lag`, an unknown `method`, ``method="fast"`` with ``lag > 0`` or n_t > 2.
    TypeError
        A model that is not an :class:`ARFieldModel`, non-numeric arguments.

    See Also
    --------
    ScalarRowFilter : The per-frame filter the fast method builds on.
    denoise : ``temporal=True`` identifies the model of a stack and runs this filter.

    Notes
    -----
    Formulas, the treatment of missing (NaN) pixels, the fast filter's design and the
    measured gains over per-frame filtering are on the method page
    :doc:`/methods/sequence_filter` (§2.5).

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel(rho=[0.95, 0.9, 0.9], order=[1, 2, 2])
    >>> x = model.sample((20, 32, 32), seed=1)
    >>> z = x + np.random.default_rng(2).normal(size=x.shape)
    >>> f = kf.SequenceFilter(model, 1.0, (32, 32), method="optimal")
    >>> estimate = f.filter(z)
    >>> bool(np.mean((estimate - x) ** 2) < 0.5 * np.mean((z - x) ** 2))
    True
    >>> f.error_variance().shape
    (32, 32)
    """

    __slots__ = (
        "_model",
        "_noise_var",
        "_shape",
        "_method",
        "_lag",
        "_mean",
        "_threads",
        "_ratio",
        "_unit",
        "_error_model",
        "_smoothing",
        "_core",
    )

    def __init__(
        self,
        model: ARFieldModel,
        noise_var: float,
        frame_shape: tuple[int, int],
        *,
        method: str = "auto",
        lag: int = 0,
        mean: float = 0.0,
        threads: int | None = None,
    ) -> None:
        self._model = sequence_model(model)
        self._noise_var = positive_float(noise_var, "noise_var")
        self._shape: tuple[int, int] = grid_shape(frame_shape, 2, "frame_shape")  # type: ignore[assignment]
        self._lag = nonnegative_int(lag, "lag")
        self._mean = real_number(mean, "mean")
        self._threads = thread_count(threads)
        self._method = self._resolve(method)
        self._unit, self._ratio = unit_scale(self._model, self._noise_var)
        self._error_model: ARFieldModel | None = None
        self._smoothing = 0.0
        if self._method == "fast":
            self._error_model, self._smoothing, _ = error_model(self._unit, self._ratio)
        self._core = self._kernel()

    def _resolve(self, method: object) -> str:
        if method not in _METHODS:
            raise ValueError(f"method must be 'auto', 'optimal' or 'fast', got {method!r}")
        n_t = self._model.order[0]
        if method == "fast" and self._lag > 0:
            raise ValueError("method='fast' has no smoother: use lag=0 or method='optimal'")
        if method == "fast" and n_t > MAX_FAST_ORDER:
            raise ValueError(
                f"method='fast' supports a temporal multiplicity up to {MAX_FAST_ORDER}, "
                f"got {n_t}: use method='optimal'"
            )
        if method == "auto":
            small = max(self._shape) <= AUTO_OPTIMAL_SIDE
            exact = small or self._lag > 0 or n_t > MAX_FAST_ORDER
            return "optimal" if exact else "fast"
        return str(method)

    def _kernel(self) -> Any:
        h, w = self._shape
        if self._method == "optimal":
            return _core.ModalSequenceFilter(self._unit._core, self._ratio, h, w, self._lag)
        assert self._error_model is not None
        return _core.FastSequenceFilter(
            self._unit._core, self._error_model._core, self._smoothing, self._ratio, h, w
        )

    # -- attributes ---------------------------------------------------------------------
    @property
    def model(self) -> ARFieldModel:
        """The field model (t, y, x)."""
        return self._model

    @property
    def noise_var(self) -> float:
        """The observation noise variance σ_θ²."""
        return self._noise_var

    @property
    def frame_shape(self) -> tuple[int, int]:
        """(H, W) of the frames."""
        return self._shape

    @property
    def method(self) -> str:
        """The method that runs: "optimal" or "fast" ("auto" resolved)."""
        return self._method

    @property
    def lag(self) -> int:
        """The smoothing lag (0: the causal filter)."""
        return self._lag

    @property
    def frames_seen(self) -> int:
        """Frames taken by :meth:`step` so far."""
        return int(self._core.state()[0])

    @property
    def error_model(self) -> ARFieldModel | None:
        """The fast filter's spatial model of the prediction error (None: exact filter).

        Its σ is in units of the field's σ.
        """
        return self._error_model

    # -- filtering ----------------------------------------------------------------------
    def _frame(self, frame: npt.ArrayLike) -> np.ndarray:
        arr = real_array(frame, "frame")
        if arr.shape != self._shape:
            raise ValueError(f"the frame has shape {arr.shape}, expected {self._shape}")
        return (arr - self._mean if self._mean else arr).ravel()

    def step(self, frame: npt.ArrayLike) -> np.ndarray | None:
        """Take the next frame and return the estimate of the newest one.

        With `lag` > 0 the estimate is that of the frame `lag` steps back.

        Parameters
        ----------
        frame : array_like
            The frame (H, W); NaN (or a masked entry) marks a missing pixel.

        Returns
        -------
        numpy.ndarray or None
            The estimate (H, W); None for the first `lag` frames of a smoother (see
            :meth:`pending`).

        Raises
        ------
        ValueError
            A frame of the wrong shape, infinite pixels.
        TypeError
            A non-numeric frame.

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> model = kf.ARFieldModel(rho=[0.9, 0.8, 0.8], order=1)
        >>> f = kf.SequenceFilter(model, 0.5, (8, 8))
        >>> f.step(np.zeros((8, 8))).shape
        (8, 8)
        """
        values = self._frame(frame)
        estimate = self._core.step(values, self._threads)
        if estimate is None:
            return None
        estimate = estimate.reshape(self._shape)
        return estimate + self._mean if self._mean else estimate

    def pending(self) -> np.ndarray:
        """The estimates of the frames a smoother has not returned yet.

        The last `lag` frames, each from every frame seen, oldest first; the stream goes on
        unchanged.

        Returns
        -------
        numpy.ndarray
            Shape (min(lag, frames seen), H, W); empty for the causal filter.

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> f = kf.SequenceFilter(kf.ARFieldModel(0.8, [1, 1, 1]), 1.0, (4, 4), lag=2)
        >>> f.step(np.ones((4, 4))) is None
        True
        >>> f.pending().shape
        (1, 4, 4)
        """
        h, w = self._shape
        if self._method == "fast":
            return np.empty((0, h, w))
        return self._core.pending().reshape(-1, h, w) + self._mean

    def filter(self, frames: npt.ArrayLike | Iterable[npt.ArrayLike]) -> np.ndarray:
        """Estimate every frame of a sequence, from a fresh start.

        The stream of :meth:`step` is left as it was.

        Parameters
        ----------
        frames : array_like or iterable of array_like
            An (F, H, W) array or any iterable of (H, W) frames; NaN marks missing pixels.

        Returns
        -------
        numpy.ndarray
            (F, H, W): the filtered frames, or with `lag` each frame smoothed with the
            `lag` newer ones (the last ones with those there are).

        Raises
        ------
        ValueError
            Frames of the wrong shape, infinite pixels.
        TypeError
            Non-numeric frames.

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> f = kf.SequenceFilter(kf.ARFieldModel(0.8, [1, 1, 1]), 1.0, (4, 4), lag=1)
        >>> f.filter(np.ones((3, 4, 4))).shape
        (3, 4, 4)
        """
        if isinstance(frames, np.ndarray) and frames.ndim != 3:
            raise ValueError(f"frames must be an (F, H, W) array, got {frames.ndim} axes")
        if not isinstance(frames, Iterable):
            raise TypeError(
                f"frames must be an (F, H, W) array or an iterable of frames, got {frames!r}"
            )
        fresh = self._fresh()
        out = [e for e in (fresh.step(f) for f in frames) if e is not None]
        out.extend(fresh.pending())
        h, w = self._shape
        return np.array(out).reshape(-1, h, w)

    def _fresh(self) -> SequenceFilter:
        other = object.__new__(SequenceFilter)
        for name in self.__slots__:
            setattr(other, name, getattr(self, name))
        other._core = other._kernel()
        return other

    def error_variance(self) -> np.ndarray:
        """The per-pixel error variance of the steady state.

        Returns
        -------
        numpy.ndarray
            (H, W). "optimal": exact, of the filtered (or `lag`-smoothed) frame. "fast": the
            error the steady row filter assumes for its model of the prediction error (an
            approximation; the method page gives the measured MSE).

        Examples
        --------
        >>> import kalmanfield as kf
        >>> f = kf.SequenceFilter(kf.ARFieldModel(0.9, [1, 1, 1]), 1.0, (6, 6))
        >>> bool(f.error_variance().max() < 1.0)
        True
        """
        h, w = self._shape
        if self._method == "optimal":
            raw = self._core.error_variance(self._threads)
        else:
            raw = self._core.error_variance()
        return in_image_units(np.asarray(raw).reshape(h, w), self._model.sigma)

    # -- pickling -----------------------------------------------------------------------
    def __reduce__(self):
        settings = {"method": self._method, "lag": self._lag, "mean": self._mean}
        settings["threads"] = self._threads
        return (
            _restore,
            (self._model, self._noise_var, self._shape, settings, self._core.state()),
        )

    def __repr__(self) -> str:
        return (
            f"SequenceFilter({self._model!r}, {self._noise_var!r}, {self._shape!r}, "
            f"method={self._method!r}, lag={self._lag})"
        )


def _restore(model, noise_var, shape, settings, state) -> SequenceFilter:
    restored = SequenceFilter(model, noise_var, shape, **settings)
    frames, *arrays = state
    restored._core.set_state(frames, *(np.ascontiguousarray(a, dtype=float) for a in arrays))
    return restored
