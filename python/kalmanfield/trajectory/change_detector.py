"""Change-point ("разладка") detection that restarts the filter (method page *Fuzzy filter*,
§4.4; [K95 8–10]), with the classical χ² and CUSUM tests of the normalised Kalman innovations
beside it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from .. import _core
from .._validation import pickled_fields, positive_float, positive_int, probability, thread_count
from ._inputs import (
    as_batch,
    next_time,
    restored_stream,
    series_array,
    step_samples,
    times_array,
    velocity_array,
)
from .motion_filter import MotionFilter

#: the tests of :class:`ChangeDetector`
METHODS = ("fuzzy", "chi2", "cusum")

#: the confidence used when none is given: [K95]'s example μ for the fuzzy test; for χ² and
#: CUSUM about one false alarm per 1,000 samples of a jump-free series (benchmark page)
DEFAULT_CONFIDENCE = {"fuzzy": 0.9, "chi2": 0.999, "cusum": 0.999}


@dataclass(frozen=True)
class ChangePoints:
    """What :meth:`ChangeDetector.run` found, every array shaped like the samples.

    Parameters
    ----------
    position, velocity : numpy.ndarray
        The estimates of the filter, restarted at every alarm.
    alarm : numpy.ndarray
        Boolean, True at the samples where a change was detected (each starts a new
        segment).
    statistic : numpy.ndarray
        The test statistic over its threshold (an alarm when > 1; NaN where no test was
        made: segment starts, missing samples, a χ² window still filling).

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield import ChangeDetector, FuzzyFilter
    >>> z = np.r_[np.zeros(30), np.full(30, 10.0)] + 0.1 * np.sin(np.arange(60))
    >>> found = ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2)).run(z)
    >>> found.alarm.shape, int(found.alarm.sum()), bool(np.isnan(found.statistic[0]))
    ((60,), 1, True)
    """

    position: np.ndarray
    velocity: np.ndarray
    alarm: np.ndarray
    statistic: np.ndarray

    def indices(self) -> np.ndarray | list[np.ndarray]:
        """Sample indices of the alarms.

        Returns
        -------
        numpy.ndarray or list of numpy.ndarray
            The indices for one series (1-D samples), or a list of them, one per series.

        Examples
        --------
        >>> import numpy as np
        >>> from kalmanfield import ChangeDetector, FuzzyFilter
        >>> z = np.r_[np.zeros(30), np.full(30, 10.0)]
        >>> ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2)).run(np.stack([z, -z])).indices()
        [array([30]), array([30])]
        """
        if self.alarm.ndim == 1:
            return np.flatnonzero(self.alarm)
        return [np.flatnonzero(row) for row in self.alarm]

    def to_frame(self) -> pd.DataFrame:
        """The alarms as a table.

        Returns
        -------
        pandas.DataFrame
            One row per alarm, columns ``series`` (0 for 1-D samples) and ``sample``.

        Examples
        --------
        >>> import numpy as np
        >>> from kalmanfield import ChangeDetector, FuzzyFilter
        >>> z = np.r_[np.zeros(30), np.full(30, 10.0)]
        >>> ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2)).run(z).to_frame()
           series  sample
        0       0      30
        """
        alarm = np.atleast_2d(self.alarm)
        series, sample = np.nonzero(alarm)
        return pd.DataFrame({"series": series, "sample": sample})


class ChangeDetector:
    """Detects jumps of a trajectory's model and restarts the filter at each one.

    Parameters
    ----------
    filter : FuzzyFilter or KalmanFilterCV
        Its spreads define the model and its estimates are returned (restarted at every
        alarm). Its own stream is not used.
    method : {"cusum", "chi2", "fuzzy"}, optional
        ``"cusum"`` (default): two-sided CUSUM of the normalised innovations of the Kalman
        filter of the same model, reference ``drift``; ``"chi2"``: the sum of the last
        ``window`` squared normalised innovations against the χ² quantile; ``"fuzzy"``: the
        recursive fuzzy test [K95 8–10], the weighted mean s_n of squared residuals of the
        fuzzy filter against -D_n ln(1 - confidence). The default won 13 of the 16
        comparisons of the change-detection study (benchmark page *Change detection*);
        ``"chi2"`` (or ``drift=1``) detects sudden position jumps in Gaussian noise about
        half a sample sooner; ``"fuzzy"`` is the source's method.
    confidence : float, optional
        The false-alarm level; default 0.9 for ``fuzzy`` ([K95]'s example), 0.999 for
        ``chi2`` and ``cusum`` (about one false alarm per 1,000 samples). ``fuzzy``: the
        source's μ (a possibility measure, no probability); ``chi2``: each test of a full
        window of a jump-free series (Gaussian model) alarms with probability
        1 - confidence; ``cusum``: the mean run length between false alarms on a jump-free
        series is 1/(1 - confidence) tested samples (at most 5·10⁷).
    window : int, optional
        W of the χ² test (1…1024, default 5).
    drift : float, optional
        The CUSUM's reference k, in units of the innovations' standard deviation
        (0 < k ≤ 10, default 0.5).

    Raises
    ------
    ValueError
        An unknown method, a confidence outside (0, 1) or beyond the CUSUM's reach, a
        window outside 1…1024, a drift outside (0, 10].
    TypeError
        A filter that is not a FuzzyFilter or a KalmanFilterCV.

    See Also
    --------
    ChangePoints : What :meth:`run` returns.

    Notes
    -----
    At an alarm at t_n the filters restart with z_n as a new segment's first sample
    (t_0 = t_n, a new least-squares start). The tests are §4.4 of the method page
    *Fuzzy filter* (:doc:`/methods/fuzzy_filter`); measured delays and false-alarm rates of
    the three methods are on the benchmark page :doc:`/benchmarks/change_detection`.
    The detector pickles mid-series and resumes exactly.

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield import ChangeDetector, FuzzyFilter
    >>> z = np.r_[np.zeros(30), np.full(30, 10.0)] + 0.1 * np.sin(np.arange(60))
    >>> found = ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2)).run(z)
    >>> found.indices()
    array([30])
    """

    def __init__(
        self,
        filter: MotionFilter,
        method: str = "cusum",
        confidence: float | None = None,
        *,
        window: int = 5,
        drift: float = 0.5,
    ) -> None:
        if not isinstance(filter, MotionFilter):
            raise TypeError(
                f"filter must be a FuzzyFilter or a KalmanFilterCV, got {type(filter).__name__}"
            )
        if method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {method!r}")
        window = positive_int(window, "window")
        if window > _core.MAX_WINDOW:
            raise ValueError(f"window must be at most {_core.MAX_WINDOW}, got {window}")
        self._filter = filter
        self._settings: dict[str, Any] = dict(
            method=method,
            confidence=probability(
                DEFAULT_CONFIDENCE[method] if confidence is None else confidence, "confidence"
            ),
            window=window,
            drift=positive_float(drift, "drift"),
        )
        self._config = _core.DetectorConfig(**self._settings)
        self.reset()

    @property
    def method(self) -> str:
        """The test: "cusum", "chi2" or "fuzzy"."""
        return str(self._settings["method"])

    @property
    def settings(self) -> dict[str, Any]:
        """The settings by name: method, confidence, window and drift."""
        return dict(self._settings)

    @property
    def threshold(self) -> float:
        """The alarm threshold: -ln(1 - μ) (fuzzy), the χ²_W quantile (chi2) or h (cusum)."""
        return self._config.threshold

    @property
    def filter(self) -> MotionFilter:
        """The filter whose estimates are returned."""
        return self._filter

    def run(
        self,
        z: npt.ArrayLike,
        times: npt.ArrayLike | None = None,
        *,
        velocity: npt.ArrayLike | None = None,
        threads: int | None = None,
    ) -> ChangePoints:
        """Run the detector over one series (1-D `z`) or many (2-D: series × samples).

        Parameters
        ----------
        z : array-like
            Position samples, (n,) or (series, n); NaN marks a missing sample (not tested).
        times : array-like, optional
            Sample times, (n,) (shared by every series) or shaped like `z` (per series);
            default 0, 1, 2, …; strictly increasing.
        velocity : array-like, optional
            Velocity samples shaped like `z` (only with a filter that has R_vel).
        threads : int, optional
            Worker threads (default: all cores); the result does not depend on it.

        Returns
        -------
        ChangePoints
            The estimates, alarms and statistics, shaped like `z`.

        Raises
        ------
        ValueError
            As :meth:`FuzzyFilter.filter`: empty or ragged `z`, infinite samples or beyond
            ±1e150, times not finite or not strictly increasing, a wrong shape, an overflow.
        TypeError
            Non-numeric input.

        Examples
        --------
        >>> import numpy as np
        >>> from kalmanfield import ChangeDetector, KalmanFilterCV
        >>> t = np.arange(80.0)
        >>> z = np.where(t < 40, 0.5 * t, 20.0 - 0.5 * (t - 40)) + 0.2 * np.cos(t)
        >>> det = ChangeDetector(KalmanFilterCV(P=1.0, Q=0.05, R=0.3, P_vel=1.0, Q_vel=0.01))
        >>> det.run(z, times=t).indices()  # the velocity jump at 40
        array([42])
        """
        arr = series_array(z)
        t = times_array(times, arr.shape)
        zv = velocity_array(velocity, arr.shape, self._filter.measures_velocity)
        two_d = arr.ndim == 2
        zv2 = None if zv is None else as_batch(zv, two_d)
        model, batch = self._filter._model, as_batch(arr, two_d)
        out = _core.detect_changes(model, self._config, batch, t, zv2, thread_count(threads))
        if not two_d:
            out = tuple(a[0] for a in out)
        return ChangePoints(*out)

    # ------------------------------------------------------------------ streaming
    def reset(self) -> None:
        """Forget the streamed samples (:meth:`step` starts afresh).

        Examples
        --------
        >>> from kalmanfield import ChangeDetector, FuzzyFilter
        >>> det = ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2))
        >>> det.step(1.0)
        (1.0, 0.0, False)
        >>> det.reset()
        >>> det.step([1.0, 2.0])  # a new stream, of two series
        (array([1., 2.]), array([0., 0.]), array([False, False]))
        """
        self._bank: Any = None
        self._scalar = True
        self._t_last: float | None = None

    def step(self, z_n: Any, t_n: float | None = None, *, velocity: Any = None):
        """Test and filter the next sample of one series (a number) or of k series.

        The steps give the same bits as :meth:`run` on the whole series; the detector
        pickles mid-series and resumes exactly.

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
            The estimate x̂_n (restarted at an alarm).
        velocity : float or numpy.ndarray
            The estimate x̂'_n.
        alarm : bool or numpy.ndarray
            Whether a change was detected at this sample.

        Raises
        ------
        ValueError
            A time that does not increase, samples of another number of series than the
            stream's (call :meth:`reset` first), velocity samples missing or not wanted.
        TypeError
            Non-numeric input.

        Examples
        --------
        >>> from kalmanfield import ChangeDetector, FuzzyFilter
        >>> det = ChangeDetector(FuzzyFilter(P=1.0, Q=0.1, R=0.2))
        >>> alarms = [det.step(z)[2] for z in [0.0] * 30 + [10.0] * 5]
        >>> alarms.index(True)
        30
        """
        z, scalar = step_samples(z_n)
        zv = None
        if velocity is not None or self._filter.measures_velocity:
            if velocity is None or not self._filter.measures_velocity:
                raise ValueError("velocity= goes with (and only with) a filter that has R_vel")
            zv, _ = step_samples(velocity, "velocity")
            if zv.shape != z.shape:
                raise ValueError("velocity must hold one sample per series")
        if self._bank is not None and (self._bank.series != z.size or self._scalar != scalar):
            raise ValueError(
                f"this stream has {self._bank.series} series; call reset() to start another"
            )
        t = next_time(t_n, self._t_last)
        bank = self._bank or _core.DetectorBank(self._filter._model, self._config, z.size)
        x, v, alarm, _ = bank.step(t, z, zv)
        self._bank, self._scalar, self._t_last = bank, scalar, t
        if scalar:
            return float(x[0]), float(v[0]), bool(alarm[0])
        return x, v, alarm

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        stream = None
        if self._bank is not None:
            stream = (self._bank.state(), self._scalar, self._t_last)
        return {"filter": self._filter, "settings": self._settings, "stream": stream}

    def __setstate__(self, state: dict[str, Any]) -> None:
        names = ("filter", "settings", "stream")
        filt, settings, stream = pickled_fields(state, "ChangeDetector", *names)
        if not isinstance(settings, dict):
            raise ValueError("the pickled ChangeDetector is altered: its settings are no dict")
        self.__init__(filt, **settings)  # type: ignore[misc]
        if stream is not None:
            bank = _core.DetectorBank(self._filter._model, self._config, 1)
            self._bank, self._scalar, self._t_last = restored_stream(bank, stream)

    def __repr__(self) -> str:
        s = self._settings
        return (
            f"ChangeDetector({self._filter!r}, method={s['method']!r}, "
            f"confidence={s['confidence']:g})"
        )
