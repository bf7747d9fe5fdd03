"""The optimal vector row Kalman filter (method page *Row filters*, §2.1–2.2)."""

from __future__ import annotations

import os

import numpy as np

from .. import _core
from .._validation import check_memory, positive_int
from ..field.model import ARFieldModel
from .base import RowFilter


class VectorRowFilter(RowFilter):
    """Optimal Kalman filter of z = x + θ row by row; the state is the last n_y rows.

    With the exact stationary start every row, the first ones included, gets
    E[x̄_t | z̄_1..z̄_t], and :meth:`error_variance` is the true per-pixel MSE; smoothed, the
    estimate is the posterior mean given the whole image, whose error is
    :func:`wiener_bound`.

    Parameters
    ----------
    model : ARFieldModel
        2-axis field model of x (axis 0 = rows), row multiplicity n_y ≤ 4.
    noise_var : float
        Variance σ_θ² of the white observation noise θ.
    width : int
        Row length W of the images.
    smooth : bool, default False
        Add the RTS smoothing pass over the rows.
    mean : float, default 0.0
        The field's mean (subtracted before filtering, added back).
    threads : int, optional
        Threads for the frames of a stack (None: all cores).

    Raises
    ------
    TypeError
        `model` is not an ARFieldModel.
    ValueError
        A model without two axes or with n_y > 4, a noise ratio outside float64's normal
        range, four rows whose correlation does not factor in float64 (n_y = 4 at
        ρ_y = 0.9999).
    MemoryError
        The W × W eigenbasis does not fit in memory.

    See Also
    --------
    ScalarRowFilter : Within a fraction of a per cent of it at O(W) per row.
    wiener_bound : The error of the smoothed filter.

    Notes
    -----
    Every matrix of the filter is a Kronecker product with the row covariance, so in its
    eigenbasis (O(W³) once) the filter splits into W independent n_y-dimensional ones:
    O(W²) per row. Each mode runs in the whitened basis of its n_y rows. Method: §2.1–2.2
    of :doc:`/methods/row_filters`; numerical range: :doc:`/accuracy`.

    References
    ----------
    .. [1] O. V. Popov, dissertation, Ulyanovsk, 2000, eqs. 3.3–3.7, 3.18–3.32 ([P] in
       :doc:`/references`).

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    >>> x = model.sample((64, 64), seed=1)
    >>> z = x + np.random.default_rng(0).normal(0, 1, x.shape)
    >>> filt = kf.VectorRowFilter(model, noise_var=1.0, width=64, smooth=True)
    >>> x_hat = filt.filter(z)
    >>> bool(abs(filt.error_variance(64).mean() - kf.wiener_bound(model, 1.0, (64, 64))) < 1e-9)
    True
    """

    __slots__ = ()

    def __init__(
        self,
        model: ARFieldModel,
        noise_var: float,
        width: int,
        smooth: bool = False,
        *,
        mean: float = 0.0,
        threads: int | None = None,
    ) -> None:
        unit, ratio = self._set_parameters(model, noise_var, width, smooth, mean, threads)
        # the row's eigenbasis, its squares and the eigensolver's workspace: W × W each
        check_memory((self._width, self._width), np.dtype(np.float64), copies=3)
        self._core = _core.VectorRowFilter(unit, ratio, self._width)

    def error_variance(self, height: int) -> np.ndarray:
        """Per-pixel error variance map (diag P) of this filter, of the smoother if smoothed.

        Parameters
        ----------
        height : int
            Image height H.

        Returns
        -------
        numpy.ndarray
            The (H, W) map.

        Raises
        ------
        MemoryError
            A map larger than the machine's memory.
        """
        height = positive_int(height, "height")
        # the map, the kernel's per-mode map of the same size and, smoothed, each worker's
        # per-row Riccati history of one mode (two 4 × 4 matrices a row)
        history = 32 * (os.cpu_count() or 1) if self._smooth else 0
        check_memory((height, 2 * self._width + history), np.dtype(np.float64))
        return self._in_image_units(self._core.error_variance(height, self._smooth))

    def __repr__(self) -> str:
        return (
            f"VectorRowFilter({self._model!r}, noise_var={self._noise_var}, "
            f"width={self._width}, smooth={self._smooth})"
        )

    def __reduce__(self):
        kwargs = {"mean": self._mean, "threads": self._threads}
        return (_rebuild, (self._model, self._noise_var, self._width, self._smooth, kwargs))


def _rebuild(model, noise_var, width, smooth, kwargs) -> VectorRowFilter:
    return VectorRowFilter(model, noise_var, width, smooth, **kwargs)
