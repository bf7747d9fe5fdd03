"""What the fuzzy filter and the Kalman filter of the same model share: spreads, batched
filtering, streaming and pickling (method page *Fuzzy filter*, §4.1–4.3)."""

from __future__ import annotations

from typing import Any, ClassVar, NamedTuple

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import pickled_fields, positive_int, real_value, thread_count
from ._inputs import (
    as_batch,
    next_time,
    output_pair,
    restored_stream,
    series_array,
    step_samples,
    times_array,
    velocity_array,
)


class TrajectoryEstimates(NamedTuple):
    """Filtered positions x̂_n and velocities x̂'_n, each shaped like the samples.

    What :meth:`FuzzyFilter.filter` and :meth:`KalmanFilterCV.filter` return; a named
    tuple, so ``position, velocity = f.filter(z)`` works too.

    Parameters
    ----------
    position : numpy.ndarray
        The estimates x̂_n, shaped like the samples (NaN before a series' first observed
        sample).
    velocity : numpy.ndarray
        The estimates x̂'_n (0 for the 1-D filter), shaped like the samples.

    Examples
    --------
    >>> from kalmanfield import FuzzyFilter
    >>> est = FuzzyFilter(P=1.0, Q=1.0, R=1.0, P_vel=1.0).filter([0.0, 1.0, 2.0, 3.0])
    >>> est.position.round(6), est.velocity.round(6)
    (array([0., 1., 2., 3.]), array([0., 1., 1., 1.]))
    """

    position: np.ndarray
    velocity: np.ndarray


TrajectoryEstimates.position.__doc__ = "The estimates x̂_n, shaped like the samples."
TrajectoryEstimates.velocity.__doc__ = "The estimates x̂'_n, shaped like the samples."


def _spread(value: Any, name: str, zero_allowed: bool) -> float:
    number = real_value(value, name)
    low_ok = number >= 0 if zero_allowed else number > 0
    if not (np.isfinite(number) and low_ok and number <= _core.MAX_SPREAD):
        kind = "non-negative" if zero_allowed else "positive"
        raise ValueError(
            f"{name} must be {kind}, finite and at most {_core.MAX_SPREAD:g}, got {number}"
        )
    return number


class MotionFilter:
    """Base of :class:`FuzzyFilter` and :class:`KalmanFilterCV`: spreads, batched filtering,
    streaming and pickling (not used directly; the subclasses set the gains' rule)."""

    _rule: ClassVar[str]

    def __init__(
        self,
        P: float,
        Q: float,
        R: float,
        P_vel: float = 0.0,
        Q_vel: float = 0.0,
        R_vel: float | None = None,
    ) -> None:
        self._spreads = (
            _spread(P, "P", False),
            _spread(Q, "Q", False),
            _spread(R, "R", False),
            _spread(P_vel, "P_vel", True),
            _spread(Q_vel, "Q_vel", True),
            None if R_vel is None else _spread(R_vel, "R_vel", False),
        )
        self._model = _core.TrajectoryModel(self._rule, *self._spreads)
        self.reset()

    # ------------------------------------------------------------------ properties
    @property
    def spreads(self) -> dict[str, float | None]:
        """The spreads by name: P, Q, R, P_vel, Q_vel and R_vel (None without it)."""
        return dict(zip(("P", "Q", "R", "P_vel", "Q_vel", "R_vel"), self._spreads))

    @property
    def measures_velocity(self) -> bool:
        """Whether velocities are measured too (R_vel given)."""
        return self._spreads[5] is not None

    @property
    def has_velocity(self) -> bool:
        """False for the 1-D filter (P_vel = Q_vel = 0 and no R_vel): velocity ≡ 0."""
        p_vel, q_vel, r_vel = self._spreads[3:]
        return p_vel > 0 or q_vel > 0 or r_vel is not None

    # ------------------------------------------------------------------ gains
    def _raw_gains(self, n: Any, times: npt.ArrayLike | None) -> tuple[np.ndarray, np.ndarray]:
        n = positive_int(n, "n")
        t = np.arange(n, dtype=float) if times is None else times_array(times, (n,))
        if t is None or t.ndim != 1:  # pragma: no cover - times_array guarantees it
            raise ValueError("times must be 1-D")
        return self._model.gains(t), t

    def gains(self, n: int, times: npt.ArrayLike | None = None) -> np.ndarray:
        """The gains (α_n, β_n) of the first `n` samples of a segment, every sample observed.

        Parameters
        ----------
        n : int
            Number of samples.
        times : array-like, optional
            The samples' times (default 0, 1, …, n-1); strictly increasing.

        Returns
        -------
        numpy.ndarray
            (n, 2) float64: α_n, the position gain, and β_n, such that the velocity
            correction is β_n (z_n - x̂^e_n)/τ_n [K95 7] (β_0 = 0). With velocity
            measurements, β_n is the gain of the velocity innovation z'_n - x̂'^e_n instead
            (:class:`KalmanFilterCV` then returns its 2 × 2 gain matrices).

        Raises
        ------
        ValueError
            A non-positive `n`, times of the wrong shape, not finite or not strictly
            increasing.

        Examples
        --------
        >>> from kalmanfield import FuzzyFilter
        >>> FuzzyFilter(P=1.0, Q=1.0, R=1.0, P_vel=1.0).gains(3).round(4)
        array([[0.5   , 0.    ],
               [0.8799, 0.1201],
               [0.8921, 0.0925]])
        """
        raw, t = self._raw_gains(n, times)
        out = raw[:, [0, 2]].copy()
        if not self.measures_velocity:
            out[1:, 1] *= np.diff(t)
        else:
            out[:, 1] = raw[:, 3]
        return out

    # ------------------------------------------------------------------ batch
    def filter(
        self,
        z: npt.ArrayLike,
        times: npt.ArrayLike | None = None,
        *,
        velocity: npt.ArrayLike | None = None,
        out: tuple[np.ndarray, np.ndarray] | None = None,
        threads: int | None = None,
    ) -> TrajectoryEstimates:
        """Filters one series (1-D `z`) or many (2-D: series × samples) at once.

        Parameters
        ----------
        z : array-like
            Position samples, (n,) or (series, n); NaN marks a missing sample (its estimate
            is the prediction; before a series' first observed sample the estimates are
            NaN).
        times : array-like, optional
            Sample times, (n,) (shared by every series) or shaped like `z` (per series);
            default 0, 1, 2, …; strictly increasing.
        velocity : array-like, optional
            Velocity samples shaped like `z` (only with R_vel; NaN = missing).
        out : tuple of two numpy.ndarray, optional
            The (position, velocity) destination: two writeable C-contiguous float64
            arrays shaped like `z` sharing no memory with it; reusing them across calls
            skips the page faults of fresh outputs (a third of the time of a large batch,
            see the benchmark page). When the filter raises, their content is unspecified.
        threads : int, optional
            Worker threads (default: all cores); the result does not depend on it.

        Returns
        -------
        TrajectoryEstimates
            ``position`` and ``velocity``, shaped like `z` (the `out` arrays when given).

        Raises
        ------
        ValueError
            Empty or ragged `z`, infinite samples or beyond ±1e150, times not finite or not
            strictly increasing, a wrong shape, spreads and time steps that overflow.
        TypeError
            Non-numeric input, or `out` not a pair of float64 arrays.

        Examples
        --------
        >>> import numpy as np
        >>> from kalmanfield import FuzzyFilter
        >>> f = FuzzyFilter(P=1.0, Q=0.1, R=0.5, P_vel=0.5, Q_vel=0.01)
        >>> z = np.array([[0.0, 1.1, 1.9, 3.2, 4.0], [5.0, 5.0, np.nan, 5.1, 4.9]])
        >>> est = f.filter(z)  # two series at once
        >>> est.position.shape, bool(np.isfinite(est.position).all())
        ((2, 5), True)
        """
        arr = series_array(z)
        t = times_array(times, arr.shape)
        zv = velocity_array(velocity, arr.shape, self.measures_velocity)
        two_d = arr.ndim == 2
        zv2 = None if zv is None else as_batch(zv, two_d)
        threads = thread_count(threads)
        if out is None:
            pos, vel = self._model.filter(as_batch(arr, two_d), t, zv2, threads)
        else:
            pos, vel = output_pair(out, arr)
            batch = as_batch(arr, two_d)
            self._model.filter_into(
                batch, as_batch(pos, two_d), as_batch(vel, two_d), t, zv2, threads
            )
        if not two_d:
            pos, vel = pos[0], vel[0]
        return TrajectoryEstimates(pos, vel)

    # ------------------------------------------------------------------ streaming
    def reset(self) -> None:
        """Forget the streamed samples (:meth:`step` starts afresh).

        Examples
        --------
        >>> from kalmanfield import FuzzyFilter
        >>> f = FuzzyFilter(P=1.0, Q=1.0, R=1.0)
        >>> f.step(2.0)
        (2.0, 0.0)
        >>> f.reset()
        >>> f.step([1.0, 3.0])  # a new stream, of two series
        (array([1., 3.]), array([0., 0.]))
        """
        self._bank: Any = None
        self._scalar = True
        self._t_last: float | None = None

    def step(self, z_n: Any, t_n: float | None = None, *, velocity: Any = None) -> tuple[Any, Any]:
        """Filter the next sample of one series (a number) or of k series (a 1-D array).

        The sequence of steps gives the same bits as :meth:`filter` on the whole series; the
        filter pickles mid-series and resumes exactly.

        Parameters
        ----------
        z_n : float or array-like
            The sample of one series, or (k,) samples of k series; NaN = missing.
        t_n : float, optional
            The samples' time; default the previous time + 1 (0 at the first step).
        velocity : float or array-like, optional
            The velocity samples, shaped like `z_n` (required with R_vel, refused without).

        Returns
        -------
        position : float or numpy.ndarray
            The estimate x̂_n: a number for one series, a (k,) array for k.
        velocity : float or numpy.ndarray
            The estimate x̂'_n, likewise.

        Raises
        ------
        ValueError
            A time that does not increase, samples of another number of series than the
            stream's (call :meth:`reset` first), velocity samples missing or not wanted.
        TypeError
            Non-numeric input.

        Examples
        --------
        >>> from kalmanfield import FuzzyFilter
        >>> f = FuzzyFilter(P=1.0, Q=1.0, R=1.0, P_vel=1.0)
        >>> [f.step(z) for z in (0.0, 1.0, 2.0)]
        [(0.0, 0.0), (1.0, 1.0), (2.0, 1.0)]
        """
        z, scalar = step_samples(z_n)
        zv = None
        if velocity is not None or self.measures_velocity:
            if velocity is None:
                raise ValueError("this filter measures velocities (R_vel given): pass velocity=")
            zv, _ = step_samples(velocity, "velocity")
            if zv.shape != z.shape:
                raise ValueError("velocity must hold one sample per series")
            if not self.measures_velocity:
                raise ValueError("velocity= needs a filter with velocity measurements (R_vel)")
        if self._bank is not None and (self._bank.series != z.size or self._scalar != scalar):
            raise ValueError(
                f"this stream has {self._bank.series} series; call reset() to start another"
            )
        t = next_time(t_n, self._t_last)
        bank = self._bank or _core.FilterBank(self._model, z.size)
        x, v = bank.step(t, z, zv)
        self._bank, self._scalar, self._t_last = bank, scalar, t
        return (float(x[0]), float(v[0])) if scalar else (x, v)

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        stream = None
        if self._bank is not None:
            stream = (self._bank.state(), self._scalar, self._t_last)
        return {"spreads": self._spreads, "stream": stream}

    def __setstate__(self, state: dict[str, Any]) -> None:
        spreads, stream = pickled_fields(state, type(self).__name__, "spreads", "stream")
        self.__init__(*spreads)  # type: ignore[misc]
        if stream is not None:
            bank = _core.FilterBank(self._model, 1)
            self._bank, self._scalar, self._t_last = restored_stream(bank, stream)

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v:g}" for k, v in self.spreads.items() if v is not None)
        return f"{type(self).__name__}({args})"
