"""The Kalman filter of the same model as the fuzzy filter: the source's comparison
(method page *Fuzzy filter*, §4.2; [K95, comparison])."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .motion_filter import MotionFilter


class KalmanFilterCV(MotionFilter):
    """Kalman filter of the constant-velocity model with covariances P², Q², R².

    State (x, x'), transition F = [[1, τ_n], [0, 1]], process covariance diag(Q², Q_vel²),
    initial covariance diag(P², P_vel²) around the same least-squares start as
    :class:`FuzzyFilter`, measurement variance R² (and R_vel² for velocity measurements) —
    the "diagonal covariance matrices with elements P², (P')², Q², (Q')²" of [K95]'s
    comparison. Same methods, batching, streaming and pickling as :class:`FuzzyFilter`.

    Parameters
    ----------
    P, Q, R : float
        Positive standard deviations of the initial position, of the position noise and of
        the measurements (at most 1e100).
    P_vel, Q_vel : float, optional
        Non-negative standard deviations of the initial velocity and of the velocity noise
        (default 0: the 1-D filter).
    R_vel : float, optional
        Standard deviation of velocity measurements (pass them as ``velocity=``).

    Raises
    ------
    ValueError
        A value that is not finite, negative (P, Q, R, R_vel: not positive) or above 1e100.
    TypeError
        A value that is not a real number.

    See Also
    --------
    FuzzyFilter : The possibility-theory filter of the same model.

    Notes
    -----
    Gains in the source's form: α_n = K_n[0], β_n = K_n[1]·τ_n, so that the correction reads
    x̂'_n = x̂'^e_n + β_n(z_n - x̂^e_n)/τ_n as for the fuzzy filter (§4.2 of the method page
    *Fuzzy filter*, :doc:`/methods/fuzzy_filter`).

    Examples
    --------
    >>> from kalmanfield import KalmanFilterCV
    >>> round(float(KalmanFilterCV(P=1.0, Q=1.0, R=1.0).gains(40)[-1, 0]), 6)  # (√5 - 1)/2
    0.618034
    """

    _rule = "kalman"

    def gains(self, n: int, times: npt.ArrayLike | None = None) -> np.ndarray:
        """The Kalman gains of the first `n` samples of a segment, every sample observed.

        Parameters
        ----------
        n : int
            Number of samples.
        times : array-like, optional
            The samples' times (default 0, 1, …, n-1); strictly increasing.

        Returns
        -------
        numpy.ndarray
            (n, 2) (α_n, β_n) with position measurements only (as
            :meth:`FuzzyFilter.gains`); with velocity measurements the full gain matrices,
            an (n, 2, 2) array K_n (x̂ = x̂^e + K_n (ν_n, ν'_n)).

        Raises
        ------
        ValueError
            A non-positive `n`, times of the wrong shape, not finite or not strictly
            increasing.

        Examples
        --------
        >>> from kalmanfield import KalmanFilterCV
        >>> KalmanFilterCV(P=1.0, Q=1.0, R=1.0, P_vel=1.0, R_vel=1.0).gains(2).shape
        (2, 2, 2)
        """
        if not self.measures_velocity:
            return super().gains(n, times)
        raw, _ = self._raw_gains(n, times)
        return raw.reshape(-1, 2, 2)
