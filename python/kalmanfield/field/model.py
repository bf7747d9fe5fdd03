"""The separable multiple-root autoregressive field model (SPEC §1.1–1.5)."""

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
    positive_float,
    positive_int,
    real_array,
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
    """Gaussian field Π_k (1 - ρ_k z_k⁻¹)^{n_k} x = β ξ, one (ρ_k, n_k) per axis (SPEC §1.2).

    Parameters
    ----------
    rho : float or sequence of float
        Correlation parameter per axis, 0 < ρ < 1, a normal float64 (a scalar is repeated
        over the axes of ``order``).
    order : int or sequence of int
        Multiplicity n ≥ 1 of the root 1/ρ per axis (1: exponential correlation, 2: the
        8-point model, higher: smoother, more isotropic fields).
    sigma : float
        Standard deviation σ of the field, within [2⁻⁵¹⁰, 2⁵¹⁰] ≈ [3.0e-154, 3.4e153]
        (σ² stays a normal float64).

    The correlation function is R(r̄) = σ² Π_k R_k(r_k) with R_k of [P 2.9]. Axis 0 is the
    slowest (C order); for space–time streams it is time.
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
        """ρ per axis."""
        return self._rho

    @property
    def order(self) -> tuple[int, ...]:
        """Root multiplicity n per axis."""
        return self._order

    @property
    def sigma(self) -> float:
        """Standard deviation of the field."""
        return self._sigma

    @property
    def ndim(self) -> int:
        """Number of axes."""
        return len(self._rho)

    @property
    def beta(self) -> float:
        """Driving-noise gain β = σ Π_k β̃_k of the template recursion [P 2.11, 2.16]."""
        return self._core.beta()

    # -- formulas -----------------------------------------------------------------------
    def coefficients(self) -> np.ndarray:
        """Template c_j̄ of shape (n_1+1, …, n_N+1), c_0̄ = 1 (SPEC §1.2, [P 2.14] with the
        sign fix): x_ī = -Σ_{j̄≠0} c_j̄ x_{ī-j̄} + β ξ_ī. At most 2**26 coefficients
        (the generator never needs the template; it runs the axis cascade)."""
        size = int(np.prod([n + 1 for n in self.order], dtype=object))
        if size > MAX_TEMPLATE:
            raise ValueError(
                f"the template of orders {self.order} holds {size} coefficients, more than "
                f"{MAX_TEMPLATE} (2**26)"
            )
        return self._core.template()

    def correlation(self, lags: npt.ArrayLike) -> np.ndarray:
        """σ² Π_k R_k(r_k) (SPEC §1.1–1.2) for lags of shape (..., N), integer or real
        (real lags use ρ^|r|·polynomial(|r|) of [P 2.9]). For a 1-axis model, lags of any
        shape whose last axis is not of length 1 are taken as scalar lags."""
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
        """A_τ = std_u τ(u) / mean_u τ(u), τ(u) = ∫_0^∞ R(t u) dt, u uniform on the unit
        sphere (SPEC §1.5, [P 2.22]); closed form in t, Gauss–Legendre over the sphere.
        Depends on the ρ of every axis (for the (1,1) model it does not: ≈ 0.10521)."""
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
    ) -> np.ndarray:
        """One realisation on a grid of `shape`, exactly stationary up to the edges
        (SPEC §1.3): the covariance of any two grid points is σ² Π_k R_k.

        Made by the axis cascade x = σ L_0 ⋯ L_{N-1} ξ (SPEC §1.2), Σ n_k multiply-adds per
        element; L_k is the stationary-start recursion of axis k.

        seed : int in [0, 2**64), numpy Generator or None (OS entropy). Each line of the last
            axis draws from its own stream keyed by (seed, line), so the result is the same on
            any number of threads.
        noise : optional driving white noise ξ, standard normal, of shape `shape` (ξ[ī] drives
            element ī). When given, `seed` is ignored. Lets the NumPy reference be fed the
            same input. ValueError when the field it makes leaves the dtype's range.
        dtype : float64 or float32. float32 runs the recursions in single precision where
            their rounding errors stay below ~1e-3 σ (1/β̃ ≤ 84 on every axis: e.g. (0.9, 2),
            (0.95, 2)); smoother models are made in float64 and rounded once (the float64
            field's values, rounded), since single-precision states drift by up to O(σ).
        threads : number of threads (None: all cores).
        """
        dims = grid_shape(shape, self.ndim)
        dt = float_dtype(dtype, self.sigma)
        given = None if noise is None else finite_noise(noise, dims)
        if dt == np.float32:  # room for the float64 copy a smooth model is made in, too
            check_memory(dims, dt, copies=3)
        out = allocate(dims, dt)
        seed_value = 0 if given is not None else resolve_seed(seed)
        threads = thread_count(threads)
        self._core.sample_into(out, seed_value, given, threads)
        if given is not None:
            check_given_noise_output(out)
        return out

    def stream(
        self,
        frame_shape: ShapeLike,
        seed: SeedLike = None,
        dtype: npt.DTypeLike = np.float64,
        threads: int | None = None,
    ) -> FieldStream:
        """An endless, stationary sequence of frames; axis 0 of the model is time
        (SPEC §1.4). See :class:`kalmanfield.FieldStream`."""
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
