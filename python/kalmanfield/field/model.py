"""The separable multiple-root autoregressive field model (method page *Random fields*,
§1.1–1.5)."""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from typing import TYPE_CHECKING, Union

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import (
    SeedLike,
    ShapeLike,
    allocate,
    check_given_noise_output,
    check_memory,
    finite_noise,
    float_dtype,
    grid_shape,
    peak_magnitude,
    positive_float,
    positive_int,
    real_array,
    real_number,
    real_value,
    resolve_seed,
    thread_count,
)

if TYPE_CHECKING:
    from .stream import FieldStream

RhoLike = Union[float, Sequence[float]]
OrderLike = Union[int, Sequence[int]]

#: Most coefficients :meth:`ARFieldModel.coefficients` makes.
MAX_TEMPLATE = 2**26
#: Most axes :meth:`ARFieldModel.anisotropy` integrates over.
MAX_ANISOTROPY_AXES = 8


def _per_axis(rho: RhoLike, order: OrderLike) -> tuple[tuple[float, ...], tuple[int, ...]]:
    rhos = _as_tuple(rho, numbers.Real, "rho", "real number")
    orders = _as_tuple(order, numbers.Integral, "order", "positive integer")
    if len(rhos) == 1 and len(orders) > 1:
        rhos = rhos * len(orders)
    if len(orders) == 1 and len(rhos) > 1:
        orders = orders * len(rhos)
    if len(rhos) != len(orders):
        raise ValueError(f"rho has {len(rhos)} axes but order has {len(orders)}")
    if not rhos:
        raise ValueError("a field model needs at least one axis")
    for r in rhos:
        value = real_value(r, "rho", "hold real numbers")
        if not 0.0 < value < 1.0:  # NaN fails this too
            raise ValueError(f"every rho must lie strictly between 0 and 1, got {value}")
    max_order = _core.MAX_ORDER
    checked = tuple(positive_int(n, "every order") for n in orders)
    if max(checked) > max_order:
        raise ValueError(f"orders above {max_order} are not supported, got {max(checked)}")
    return tuple(float(r) for r in rhos), checked


def _as_tuple(value: object, kind: type, name: str, what: str) -> tuple:
    """A scalar (a 0-d array too) as a 1-tuple, a sequence as a tuple, else a TypeError."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, kind):
        return (value,)
    try:
        return tuple(value)  # type: ignore[arg-type]
    except TypeError:
        raise TypeError(f"{name} must be a {what} or a sequence of them, got {value!r}") from None


class ARFieldModel:
    """Separable Gaussian AR field with a multiple root per axis.

    The field solves Π_k (1 − ρ_k z_k⁻¹)^{n_k} x = β ξ, one (ρ_k, n_k) per axis, with ξ
    white N(0, 1); its correlation function is σ² Π_k R_k(r_k).

    Parameters
    ----------
    rho : float or sequence of float
        Correlation parameter ρ per axis, 0 < ρ < 1 (a scalar is repeated over the axes of
        `order`).
    order : int or sequence of int
        Multiplicity n of the root 1/ρ per axis, 1 ≤ n ≤ 16 (1: exponential correlation,
        2: the 8-point model, higher: smoother, more isotropic fields). A scalar is
        repeated over the axes of `rho`.
    sigma : float, default 1.0
        Standard deviation σ of the field, within [2⁻⁵¹⁰, 2⁵¹⁰] ≈ [3.0e-154, 3.4e153].

    Raises
    ------
    ValueError
        ρ outside (0, 1) or NaN, an order outside 1..16, lengths of `rho` and `order` that
        differ, σ out of range.
    TypeError
        Parameters that are not real numbers (or integers for `order`).

    See Also
    --------
    FieldStream : Frames of a model whose axis 0 is time.
    sample_product_field : A non-Gaussian field with the same correlation.
    identify : A model fitted to data.

    Notes
    -----
    Axis 0 is the slowest (C order); for space–time models it is time. The formulas, with
    the fixes to the source's typos, are on the method page :doc:`/methods/random_fields`
    (§1.1–1.2); :doc:`/accuracy` gives the numerical range of each method.

    References
    ----------
    .. [1] O. V. Popov, dissertation, Ulyanovsk, 2000, ch. 2 ([P] in :doc:`/references`).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel(rho=[0.9, 0.9], order=[2, 2])  # the 8-point model
    >>> model.sample((256, 256), seed=1).shape
    (256, 256)
    >>> model.correlation([[0, 0], [1, 2]]).round(4)
    array([1.    , 0.9746])
    """

    __slots__ = ("_rho", "_order", "_sigma", "_core")

    def __init__(self, rho: RhoLike, order: OrderLike, sigma: float = 1.0) -> None:
        self._rho, self._order = _per_axis(rho, order)
        self._sigma: float = positive_float(sigma, "sigma")
        rho, order = list(self._rho), list(self._order)
        self._core: _core.FieldModel = _core.FieldModel(rho, order, self._sigma)

    # -- attributes ---------------------------------------------------------------------
    @property
    def rho(self) -> tuple[float, ...]:
        """The correlation parameter ρ of each axis (a tuple)."""
        return self._rho

    @property
    def order(self) -> tuple[int, ...]:
        """The root multiplicity n of each axis (a tuple)."""
        return self._order

    @property
    def sigma(self) -> float:
        """The standard deviation σ of the field."""
        return self._sigma

    @property
    def ndim(self) -> int:
        """The number of axes."""
        return len(self._rho)

    @property
    def beta(self) -> float:
        """The driving-noise gain β = σ Π_k β̃_k of the template recursion (§1.2)."""
        return self._core.beta()

    # -- formulas -----------------------------------------------------------------------
    def coefficients(self) -> np.ndarray:
        """Coefficients c of the template recursion x_ī = −Σ_{j̄≠0} c_j̄ x_{ī−j̄} + β ξ_ī.

        Returns
        -------
        numpy.ndarray
            Shape (n_1 + 1, …, n_N + 1), c_0̄ = 1 (method page :doc:`/methods/random_fields`,
            §1.2, with the sign fix of [P 2.14]).

        Raises
        ------
        ValueError
            The template would hold more than 2**26 coefficients (the generator never needs
            it: it runs the axis cascade).

        Examples
        --------
        >>> import kalmanfield as kf
        >>> kf.ARFieldModel(0.5, [1, 1]).coefficients()
        array([[ 1.  , -0.5 ],
               [-0.5 ,  0.25]])
        """
        size = int(np.prod([n + 1 for n in self.order], dtype=object))
        if size > MAX_TEMPLATE:
            raise ValueError(
                f"the template of orders {self.order} holds {size} coefficients, more than "
                f"{MAX_TEMPLATE} (2**26)"
            )
        return self._core.template()

    def correlation(self, lags: npt.ArrayLike) -> np.ndarray:
        """Correlation function σ² Π_k R_k(r_k) at the given lags.

        Parameters
        ----------
        lags : array_like
            Lags of shape (..., N), integer or real (a real lag r uses the extension
            ``ρ^|r| · polynomial(|r|)``, §1.1). For a 1-axis model, lags whose last axis is not of
            length 1 are scalar lags.

        Returns
        -------
        numpy.ndarray
            The covariances, of shape ``lags.shape[:-1]``.

        Raises
        ------
        ValueError
            Lags of the wrong shape, NaN or infinite lags.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> kf.ARFieldModel(0.5, 1).correlation([0, 1, 2.5]).round(4)
        array([1.    , 0.5   , 0.1768])
        """
        shape: tuple[int, ...] = np.shape(lags)  # (real_array makes a 0-d input 1-d)
        arr = real_array(lags, "lags").reshape(shape)
        if self.ndim == 1 and (arr.ndim == 0 or arr.shape[-1] != 1):
            arr = arr[..., np.newaxis]
        if arr.ndim == 0 or arr.shape[-1] != self.ndim:
            raise ValueError(f"lags must have shape (..., {self.ndim}), got {arr.shape}")
        if not np.all(np.isfinite(arr)):
            raise ValueError("lags contain NaN or infinite values")
        flat = np.ascontiguousarray(arr.reshape(-1, self.ndim))
        return self._core.correlation(flat).reshape(arr.shape[:-1])

    def anisotropy(self) -> float:
        """Anisotropy coefficient A_τ = std_u τ(u) / mean_u τ(u), τ(u) = ∫₀^∞ R(t u) dt.

        u runs uniformly over the unit sphere (§1.5 of :doc:`/methods/random_fields`, [P 2.22]).

        Returns
        -------
        float
            A_τ; it depends on the ρ of every axis (for the (1,1) model it does not:
            0.10509).

        Raises
        ------
        ValueError
            A model of one axis, or of more than 8 axes.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> round(kf.ARFieldModel(0.5, [1, 1]).anisotropy(), 5)
        0.10509
        """
        if self.ndim < 2:
            raise ValueError("anisotropy needs a model with at least two axes")
        if self.ndim > MAX_ANISOTROPY_AXES:
            # (a product rule of 8 nodes per angle: 8^(N-1) directions, 1.4 s for 8 axes)
            raise ValueError(
                f"anisotropy is computed for at most {MAX_ANISOTROPY_AXES} axes, "
                f"the model has {self.ndim}"
            )
        return self._core.anisotropy()

    # -- simulation ---------------------------------------------------------------------
    def sample(
        self,
        shape: ShapeLike,
        seed: SeedLike = None,
        noise: npt.ArrayLike | None = None,
        dtype: npt.DTypeLike = np.float64,
        threads: int | None = None,
        *,
        mean: float = 0.0,
    ) -> np.ndarray:
        """One realisation on a grid, exactly stationary up to the edges.

        The covariance of any two grid points is σ² Π_k R_k, edges and corners included
        (§1.3 of :doc:`/methods/random_fields`).

        Parameters
        ----------
        shape : int or tuple of int
            Grid shape, one length per axis of the model.
        seed : int, numpy.random.Generator or None, default None
            Seed in [0, 2**64); None draws fresh OS entropy. The same seed gives the same
            bits on any number of threads.
        noise : array_like, optional
            Driving white noise ξ, standard normal, of shape `shape` (ξ[ī] drives element
            ī); `seed` is then ignored.
        dtype : {numpy.float64, numpy.float32}, default numpy.float64
            Output dtype. float32 runs the recursions in single precision only where their
            rounding stays below ~1e-3 σ; other models are made in float64 and rounded once.
        threads : int, optional
            Number of threads (None: all cores).
        mean : float, default 0.0
            Added to every element: the field's mean (e.g. ``identify(data).mean``, so a
            sample of a fitted model looks like the data).

        Returns
        -------
        numpy.ndarray
            The field, of `shape` and `dtype`.

        Raises
        ------
        ValueError
            A shape that does not match the model, given noise of the wrong shape or not
            finite (or whose field leaves the dtype's range), a model whose exact start is
            beyond float64 (see :doc:`/accuracy`), a mean that is not finite or moves the
            field out of the dtype's range.
        MemoryError
            A grid larger than the machine's memory.

        Notes
        -----
        Made by the axis cascade x = σ L_0 ⋯ L_{N−1} ξ (§1.2): Σ_k n_k multiply-adds per
        element, the GIL released, large grids on all cores. Each line of the last axis
        draws from its own random stream keyed by (seed, line).

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> x = kf.ARFieldModel([0.9, 0.9], [2, 2]).sample((512, 512), seed=1, dtype=np.float32)
        >>> x.dtype
        dtype('float32')
        """
        dims = grid_shape(shape, self.ndim)
        dt = float_dtype(dtype, self.sigma)
        given = None if noise is None else finite_noise(noise, dims)
        if dt == np.float32:  # room for the float64 copy a smooth model is made in, too
            check_memory(dims, dt, copies=3)
        out = allocate(dims, dt)
        seed_value = 0 if given is not None else resolve_seed(seed)
        threads = thread_count(threads)
        mean = real_number(mean, "mean")
        self._core.sample_into(out, seed_value, given, threads)
        if given is not None:
            check_given_noise_output(out)
        if mean:
            out += out.dtype.type(mean)
            if not np.isfinite(peak_magnitude(out)):
                raise ValueError(f"the field plus mean {mean:g} leaves {out.dtype}'s range")
        return out

    def stream(
        self,
        frame_shape: ShapeLike,
        seed: SeedLike = None,
        dtype: npt.DTypeLike = np.float64,
        threads: int | None = None,
    ) -> FieldStream:
        """An endless, stationary sequence of frames; axis 0 of the model is time.

        Parameters
        ----------
        frame_shape : int or tuple of int
            Shape of a frame (the model's axes after the first).
        seed : int, numpy.random.Generator or None, default None
            Seed of the stream (None: OS entropy).
        dtype : {numpy.float64, numpy.float32}, default numpy.float64
            Dtype of the frames.
        threads : int, optional
            Number of threads per frame (None: all cores).

        Returns
        -------
        FieldStream
            The stream (§1.4 of :doc:`/methods/random_fields`).

        Examples
        --------
        >>> import kalmanfield as kf
        >>> video = kf.ARFieldModel([0.95, 0.9, 0.9], [1, 2, 2]).stream((64, 64), seed=7)
        >>> next(video).shape
        (64, 64)
        """
        from .stream import FieldStream

        return FieldStream(self, frame_shape, seed=seed, dtype=dtype, threads=threads)

    # -- Python protocol ----------------------------------------------------------------
    def __repr__(self) -> str:
        return f"ARFieldModel(rho={self._rho}, order={self._order}, sigma={self._sigma})"

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, ARFieldModel):
            return NotImplemented
        return (self._rho, self._order, self._sigma) == (other._rho, other._order, other._sigma)

    def __hash__(self) -> int:
        return hash((self._rho, self._order, self._sigma))

    def __reduce__(self):
        return (ARFieldModel, (self._rho, self._order, self._sigma))
