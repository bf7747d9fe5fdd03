"""The linear-Gaussian model of one type of object, with its prior."""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import (
    SeedLike,
    check_memory,
    nonnegative_int,
    pickled_fields,
    positive_float,
    positive_int,
    real_array,
    real_number,
    resolve_seed,
)

#: prior std of the non-stationary state components of the motion models, in measurement
#: stds (per frame for the derivatives): a diffuse prior
DIFFUSE = 1000.0

_NAMES = ("F", "Q", "H", "R", "x0", "P0")


def _matrix(value: npt.ArrayLike, name: str, ndim: int) -> np.ndarray:
    a = real_array(value, name)
    if a.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {a.shape}")
    return a


def _axes(dt: float, ndim: int, measurement_std: float, per_axis: int) -> tuple[float, int, float]:
    """The checked (dt, ndim, measurement_std) of a motion model with `per_axis` state
    components per axis."""
    ndim = positive_int(ndim, "ndim")
    check_motion_memory(per_axis, ndim)
    return positive_float(dt, "dt"), ndim, positive_float(measurement_std, "measurement_std")


def check_motion_memory(per_axis: int, ndim: int) -> None:
    """MemoryError when the n × n matrices (n = per_axis · ndim) of a motion model and its
    prior would exceed the memory this process may take: the Rust builders would abort."""
    n = per_axis * ndim
    check_memory((n, n), np.dtype(np.float64), copies=8)


def _diffuse_prior(per_axis: list[float], ndim: int) -> tuple[np.ndarray, np.ndarray]:
    variances = np.tile(np.asarray(per_axis, dtype=float) ** 2, ndim)
    return np.zeros(len(variances)), np.diag(variances)


class LinearGaussianModel:
    """The linear-Gaussian state-space model of one type of object, with its prior.

    x(k) = F x(k−1) + w, w ~ N(0, Q); z(k) = H x(k) + v, v ~ N(0, R); prior N(x0, P0) for
    the state one step before the first frame.

    Parameters
    ----------
    F, Q, H, R : array-like
        Transition (n × n), process-noise covariance (n × n, symmetric positive
        semi-definite), observation (m × n) and measurement-noise covariance (m × m,
        symmetric positive definite).
    x0, P0 : array-like
        Prior mean (n,) and covariance (n × n, symmetric positive semi-definite) of the state
        one step *before* the first frame (every frame predicts first, as in FilterPy).
    name : str, optional
        The type's name (default ``"model"``; the constructors name it after themselves).

    Raises
    ------
    ValueError
        Inconsistent dimensions, non-finite entries, non-symmetric or indefinite
        covariances.

    See Also
    --------
    TypeIdentifier : A bank of these models deciding an object's type.
    IMMEstimator : These models switching by a Markov chain.

    Notes
    -----
    Covariances are stored symmetrised, (A + Aᵀ)/2, after a check that allows asymmetry and
    negative eigenvalues of 1e-10 relative size; the arrays are read-only. The model
    pickles and compares equal (``==``) when its arrays and name are equal. The motion
    models (:meth:`constant_velocity`, :meth:`constant_acceleration`, :meth:`singer`,
    :meth:`markov_velocity`) are §6.2 of :doc:`/methods/kalman_bank`.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> walk = kf.LinearGaussianModel(
    ...     F=[[1.0]], Q=[[0.1]], H=[[1.0]], R=[[0.5]], x0=[0.0], P0=[[1.0]], name="walk"
    ... )
    >>> walk
    LinearGaussianModel(name='walk', state_dim=1, measurement_dim=1)
    >>> m = kf.LinearGaussianModel.singer(dt=1.0, rho=0.9, sigma_a=0.5, ndim=2)
    >>> m.state_dim, m.measurement_dim
    (6, 2)
    """

    def __init__(
        self,
        F: npt.ArrayLike,
        Q: npt.ArrayLike,
        H: npt.ArrayLike,
        R: npt.ArrayLike,
        x0: npt.ArrayLike,
        P0: npt.ArrayLike,
        name: str | None = None,
    ) -> None:
        arrays = [
            _matrix(a, n, 1 if n == "x0" else 2) for a, n in zip((F, Q, H, R, x0, P0), _NAMES)
        ]
        checked = _core.filterbank_check_model(*arrays)
        for a in checked:
            a.flags.writeable = False
        self._arrays: tuple[np.ndarray, ...] = tuple(checked)
        self.name = "model" if name is None else str(name)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def constant_velocity(
        cls,
        dt: float,
        q: float,
        ndim: int = 2,
        measurement_std: float = 1.0,
        *,
        x0: npt.ArrayLike | None = None,
        P0: npt.ArrayLike | None = None,
        name: str | None = "constant_velocity",
    ) -> LinearGaussianModel:
        """Constant velocity, driven by continuous white acceleration.

        Per axis F = [[1, T], [0, 1]] and Q = q [[T³/3, T²/2], [T²/2, T]] (§6.2 of
        :doc:`/methods/kalman_bank`).

        Parameters
        ----------
        dt : float
            Time step T between frames (positive).
        q : float
            Power spectral density of the white acceleration (non-negative), in
            length²/time³.
        ndim : int, default 2
            Number of spatial axes; the per-axis blocks repeat block-diagonally, the state
            ordered axis after axis.
        measurement_std : float, default 1.0
            Standard deviation σ_z of the measured positions: R = σ_z² I.
        x0 : array-like, optional
            Prior mean of the state (default zeros).
        P0 : array-like, optional
            Prior covariance of the state (default: diffuse, std 1000 σ_z for positions and
            1000 σ_z / T for velocities).
        name : str, optional
            The type's name (default ``"constant_velocity"``).

        Returns
        -------
        LinearGaussianModel
            The model, positions observed.

        Raises
        ------
        ValueError
            A non-positive `dt`, `ndim` or `measurement_std`, a negative or non-finite `q`,
            or a prior of the wrong shape.
        MemoryError
            An `ndim` whose state matrices would not fit in memory.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.constant_velocity(1.0, q=0.1, ndim=1)
        >>> m.F
        array([[1., 1.],
               [0., 1.]])
        """
        dt, ndim, sz = _axes(dt, ndim, measurement_std, 2)
        f, qm, h, r = _core.kalman_constant_velocity(dt, real_number(q, "q"), ndim, sz)
        default = _diffuse_prior([DIFFUSE * sz, DIFFUSE * sz / dt], ndim)
        return cls._built(f, qm, h, r, x0, P0, default, name)

    @classmethod
    def constant_acceleration(
        cls,
        dt: float,
        q: float,
        ndim: int = 2,
        measurement_std: float = 1.0,
        *,
        x0: npt.ArrayLike | None = None,
        P0: npt.ArrayLike | None = None,
        name: str | None = "constant_acceleration",
    ) -> LinearGaussianModel:
        """Constant acceleration, driven by continuous white jerk.

        Per axis F = [[1, T, T²/2], [0, 1, T], [0, 0, 1]] and Q = q times a fixed matrix of
        powers of T (written out in §6.2 of :doc:`/methods/kalman_bank`).

        Parameters
        ----------
        dt : float
            Time step T between frames (positive).
        q : float
            Power spectral density of the white jerk (non-negative), in length²/time⁵.
        ndim : int, default 2
            Number of spatial axes; the per-axis blocks repeat block-diagonally, the state
            ordered axis after axis.
        measurement_std : float, default 1.0
            Standard deviation σ_z of the measured positions: R = σ_z² I.
        x0 : array-like, optional
            Prior mean of the state (default zeros).
        P0 : array-like, optional
            Prior covariance of the state (default: diffuse, std 1000 σ_z for positions,
            1000 σ_z / T for velocities and 1000 σ_z / T² for accelerations).
        name : str, optional
            The type's name (default ``"constant_acceleration"``).

        Returns
        -------
        LinearGaussianModel
            The model, positions observed.

        Raises
        ------
        ValueError
            A non-positive `dt`, `ndim` or `measurement_std`, a negative or non-finite `q`,
            or a prior of the wrong shape.
        MemoryError
            An `ndim` whose state matrices would not fit in memory.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.constant_acceleration(0.5, q=1.0, ndim=2)
        >>> m.state_dim, m.measurement_dim
        (6, 2)
        """
        dt, ndim, sz = _axes(dt, ndim, measurement_std, 3)
        f, qm, h, r = _core.kalman_constant_acceleration(dt, real_number(q, "q"), ndim, sz)
        default = _diffuse_prior([DIFFUSE * sz, DIFFUSE * sz / dt, DIFFUSE * sz / dt**2], ndim)
        return cls._built(f, qm, h, r, x0, P0, default, name)

    @classmethod
    def singer(
        cls,
        dt: float,
        rho: float,
        sigma_a: float,
        ndim: int = 2,
        measurement_std: float = 1.0,
        *,
        x0: npt.ArrayLike | None = None,
        P0: npt.ArrayLike | None = None,
        name: str | None = "singer",
    ) -> LinearGaussianModel:
        """Singer-type manoeuvre model: the acceleration a first-order Markov sequence.

        Per axis F = [[1, T, T²/2], [0, 1, T], [0, 0, ρ]] and Q = diag(0, 0, σ_a²(1 − ρ²))
        ([I] eq. 8; §6.2 of :doc:`/methods/kalman_bank`).

        Parameters
        ----------
        dt : float
            Time step T between frames (positive).
        rho : float
            Correlation coefficient ρ of the acceleration per frame, in [−1, 1].
        sigma_a : float
            Stationary standard deviation σ_a of the acceleration (non-negative).
        ndim : int, default 2
            Number of spatial axes; the per-axis blocks repeat block-diagonally, the state
            ordered axis after axis.
        measurement_std : float, default 1.0
            Standard deviation σ_z of the measured positions: R = σ_z² I.
        x0 : array-like, optional
            Prior mean of the state (default zeros).
        P0 : array-like, optional
            Prior covariance of the state (default: diffuse position and velocity, std
            1000 σ_z and 1000 σ_z / T; acceleration at its stationary std σ_a).
        name : str, optional
            The type's name (default ``"singer"``).

        Returns
        -------
        LinearGaussianModel
            The model, positions observed.

        Raises
        ------
        ValueError
            A non-positive `dt`, `ndim` or `measurement_std`, `rho` outside [−1, 1], a
            negative or non-finite `sigma_a`, or a prior of the wrong shape.
        MemoryError
            An `ndim` whose state matrices would not fit in memory.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.singer(1.0, rho=0.5, sigma_a=1.0, ndim=1)
        >>> m.F
        array([[1. , 1. , 0.5],
               [0. , 1. , 1. ],
               [0. , 0. , 0.5]])
        """
        dt, ndim, sz = _axes(dt, ndim, measurement_std, 3)
        rho, sigma_a = real_number(rho, "rho"), real_number(sigma_a, "sigma_a")
        f, qm, h, r = _core.kalman_singer(dt, rho, sigma_a, ndim, sz)
        default = _diffuse_prior([DIFFUSE * sz, DIFFUSE * sz / dt, sigma_a], ndim)
        return cls._built(f, qm, h, r, x0, P0, default, name)

    @classmethod
    def markov_velocity(
        cls,
        dt: float,
        rho: float,
        sigma: float,
        ndim: int = 2,
        measurement_std: float = 1.0,
        *,
        x0: npt.ArrayLike | None = None,
        P0: npt.ArrayLike | None = None,
        name: str | None = "markov_velocity",
    ) -> LinearGaussianModel:
        """Markov velocity: the velocity a first-order Markov sequence.

        Per axis F = [[1, T], [0, ρ]] and Q = diag(0, σ²(1 − ρ²)) ([I] eq. 7; §6.2 of
        :doc:`/methods/kalman_bank`).

        Parameters
        ----------
        dt : float
            Time step T between frames (positive).
        rho : float
            Correlation coefficient ρ of the velocity per frame, in [−1, 1].
        sigma : float
            Stationary standard deviation σ of the velocity (non-negative).
        ndim : int, default 2
            Number of spatial axes; the per-axis blocks repeat block-diagonally, the state
            ordered axis after axis.
        measurement_std : float, default 1.0
            Standard deviation σ_z of the measured positions: R = σ_z² I.
        x0 : array-like, optional
            Prior mean of the state (default zeros).
        P0 : array-like, optional
            Prior covariance of the state (default: diffuse position, std 1000 σ_z;
            velocity at its stationary std σ).
        name : str, optional
            The type's name (default ``"markov_velocity"``).

        Returns
        -------
        LinearGaussianModel
            The model, positions observed.

        Raises
        ------
        ValueError
            A non-positive `dt`, `ndim` or `measurement_std`, `rho` outside [−1, 1], a
            negative or non-finite `sigma`, or a prior of the wrong shape.
        MemoryError
            An `ndim` whose state matrices would not fit in memory.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.9, sigma=2.0, ndim=1)
        >>> m.Q
        array([[0.  , 0.  ],
               [0.  , 0.76]])
        """
        dt, ndim, sz = _axes(dt, ndim, measurement_std, 2)
        rho, sigma = real_number(rho, "rho"), real_number(sigma, "sigma")
        f, qm, h, r = _core.kalman_markov_velocity(dt, rho, sigma, ndim, sz)
        default = _diffuse_prior([DIFFUSE * sz, sigma], ndim)
        return cls._built(f, qm, h, r, x0, P0, default, name)

    @classmethod
    def _built(cls, f, q, h, r, x0, p0, default, name) -> LinearGaussianModel:
        x0 = default[0] if x0 is None else x0
        p0 = default[1] if p0 is None else p0
        return cls(f, q, h, r, x0, p0, name=name)

    # ------------------------------------------------------------------ properties
    @property
    def F(self) -> np.ndarray:  # noqa: N802 - the standard name
        """The transition matrix F (n × n, read-only)."""
        return self._arrays[0]

    @property
    def Q(self) -> np.ndarray:  # noqa: N802
        """The process-noise covariance Q (n × n, read-only)."""
        return self._arrays[1]

    @property
    def H(self) -> np.ndarray:  # noqa: N802
        """The observation matrix H (m × n, read-only)."""
        return self._arrays[2]

    @property
    def R(self) -> np.ndarray:  # noqa: N802
        """The measurement-noise covariance R (m × m, read-only)."""
        return self._arrays[3]

    @property
    def x0(self) -> np.ndarray:
        """The prior mean x0 (n,) of the state one step before the first frame."""
        return self._arrays[4]

    @property
    def P0(self) -> np.ndarray:  # noqa: N802
        """The prior covariance P0 (n × n, read-only)."""
        return self._arrays[5]

    @property
    def state_dim(self) -> int:
        """The length n of the state."""
        return self.F.shape[0]

    @property
    def measurement_dim(self) -> int:
        """The length m of a measurement."""
        return self.H.shape[0]

    def arrays(self) -> tuple[np.ndarray, ...]:
        """The model's arrays, as the Rust core takes them.

        Returns
        -------
        tuple of numpy.ndarray
            (F, Q, H, R, x0, P0), read-only.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.9, sigma=1.0, ndim=1)
        >>> [a.shape for a in m.arrays()]
        [(2, 2), (2, 2), (1, 2), (1, 1), (2,), (2, 2)]
        """
        return self._arrays

    def with_prior(self, x0: npt.ArrayLike, P0: npt.ArrayLike) -> LinearGaussianModel:  # noqa: N803
        """The same dynamics with another prior.

        Parameters
        ----------
        x0 : array-like
            Prior mean (n,) of the state one step before the first frame.
        P0 : array-like
            Prior covariance (n × n, symmetric positive semi-definite).

        Returns
        -------
        LinearGaussianModel
            A new model of the same F, Q, H, R and name.

        Raises
        ------
        ValueError
            A prior of the wrong shape, non-finite, asymmetric or indefinite.

        Examples
        --------
        >>> import numpy as np
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.markov_velocity(1.0, rho=0.9, sigma=1.0, ndim=1)
        >>> m.with_prior(np.zeros(2), np.eye(2)).P0
        array([[1., 0.],
               [0., 1.]])
        """
        f, q, h, r = self._arrays[:4]
        return LinearGaussianModel(f, q, h, r, x0, P0, name=self.name)

    # ------------------------------------------------------------------ simulation
    def simulate(
        self,
        n_frames: int,
        n_trajectories: int | None = None,
        seed: SeedLike = 0,
        *,
        start: npt.ArrayLike | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Simulate states and measurements of the model.

        Parameters
        ----------
        n_frames : int
            Number of frames (non-negative).
        n_trajectories : int, optional
            Number of independent trajectories; None (default) simulates one, without the
            leading trajectory axis.
        seed : int, numpy.random.Generator or None, default 0
            Seed of NumPy's PCG64 generator, or a Generator to draw from.
        start : array-like, optional
            The state (n,) one step before the first frame, the same for every trajectory.
            By default it is drawn from the prior N(x0, P0), which for the motion models'
            diffuse default prior means velocities of hundreds of measurement stds: give
            `start` (or a prior) for realistic objects.

        Returns
        -------
        states : numpy.ndarray
            (n_frames, n), or (n_trajectories, n_frames, n).
        measurements : numpy.ndarray
            (n_frames, m), or (n_trajectories, n_frames, m).

        Raises
        ------
        ValueError
            A negative `n_frames`, a non-positive `n_trajectories`, a bad seed, a `start`
            that is not n finite values, or states beyond the range of float64.

        Notes
        -----
        The noises are drawn with square roots of the covariances by symmetric
        eigendecomposition, so semi-definite covariances are fine.

        Examples
        --------
        >>> import kalmanfield as kf
        >>> m = kf.LinearGaussianModel.singer(1.0, rho=0.5, sigma_a=1.0, ndim=1)
        >>> states, z = m.simulate(5, seed=0, start=[0.0, 1.0, 0.0])
        >>> states.shape, z.shape
        ((5, 3), (5, 1))
        >>> m.simulate(5, 3, seed=0)[1].shape
        (3, 5, 1)
        """
        frames = nonnegative_int(n_frames, "n_frames")
        b = 1 if n_trajectories is None else positive_int(n_trajectories, "n_trajectories")
        rng = np.random.default_rng(resolve_seed(seed))
        f, q, h, r, x0, p0 = self._arrays
        roots = [_root(p0), _root(q), _root(r)]
        n, m = self.state_dim, self.measurement_dim
        if start is None:
            x = x0 + rng.standard_normal((b, n)) @ roots[0].T
        else:
            first = _matrix(start, "start", 1)
            if first.shape != (n,) or not np.isfinite(first).all():
                raise ValueError(f"start must be {n} finite values, got {first}")
            x = np.tile(first, (b, 1))
        states, z = np.empty((b, frames, n)), np.empty((b, frames, m))
        with np.errstate(over="ignore", invalid="ignore"):  # (an overflow raises below)
            for t in range(frames):
                x = x @ f.T + rng.standard_normal((b, n)) @ roots[1].T
                states[:, t] = x
                z[:, t] = x @ h.T + rng.standard_normal((b, m)) @ roots[2].T
        if not (np.isfinite(states).all() and np.isfinite(z).all()):
            raise ValueError(
                "the simulation overflows float64: the model's matrices, its prior or `start` "
                "are too large for the number of frames"
            )
        if n_trajectories is None:
            return states[0], z[0]
        return states, z

    # ------------------------------------------------------------------ dunder
    def __eq__(self, other: object) -> bool:
        if not isinstance(other, LinearGaussianModel):
            return NotImplemented
        same = all(np.array_equal(a, b) for a, b in zip(self._arrays, other._arrays))
        return same and self.name == other.name

    __hash__ = None  # type: ignore[assignment]

    def __getstate__(self) -> dict[str, Any]:
        arrays = [a.copy() for a in self._arrays]
        return {"arrays": arrays, "name": self.name, "digest": _digest(arrays)}

    def __setstate__(self, state: dict[str, Any]) -> None:
        arrays, name = pickled_fields(state, "LinearGaussianModel", "arrays", "name")
        # a valid but altered matrix (an entry of F grown to 1e209) passes the constructor's
        # checks and overflows frames later: the digest refuses it now (pickles made before
        # the digest existed have none)
        if "digest" in state and state["digest"] != _digest(arrays):
            raise ValueError("the pickled LinearGaussianModel is altered: its matrices changed")
        self.__init__(*arrays, name=name)  # type: ignore[misc]

    def __repr__(self) -> str:
        return (
            f"LinearGaussianModel(name={self.name!r}, state_dim={self.state_dim}, "
            f"measurement_dim={self.measurement_dim})"
        )


def _digest(arrays: Any) -> str:
    """A BLAKE2 digest of the model's matrices (shapes, dtypes and values)."""
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        a = np.asarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _root(cov: np.ndarray) -> np.ndarray:
    """A square root A (A Aᵀ = cov) of a positive semi-definite matrix."""
    values, vectors = np.linalg.eigh(cov)
    return vectors * np.sqrt(np.clip(values, 0.0, None))
