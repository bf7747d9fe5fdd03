"""The Kalman filter of the same model as the fuzzy filter: the source's comparison
(SPEC §4, [K95, comparison])."""

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
    P, Q, R, P_vel, Q_vel, R_vel : standard deviations, as the spreads of
        :class:`FuzzyFilter` (P, Q, R positive; P_vel, Q_vel non-negative; R_vel optional).

    Notes
    -----
    Gains in the source's form: α_n = K_n[0], β_n = K_n[1]·τ_n, so that the correction reads
    x̂'_n = x̂'^e_n + β_n(z_n - x̂^e_n)/τ_n as for the fuzzy filter. See the method page
    *Fuzzy filter* (:doc:`/methods/fuzzy_filter`).

    Examples
    --------
    >>> from kalmanfield import KalmanFilterCV
    >>> round(float(KalmanFilterCV(P=1.0, Q=1.0, R=1.0).gains(40)[-1, 0]), 6)  # (√5 - 1)/2
    0.618034
    """

    _rule = "kalman"

    def gains(self, n: int, times: npt.ArrayLike | None = None) -> np.ndarray:
        """The Kalman gains of the first `n` samples of a segment, every sample observed.

        Returns
        -------
        (n, 2) array (α_n, β_n) with position measurements only; with velocity measurements
        the full gain matrices, an (n, 2, 2) array K_n (x̂ = x̂^e + K_n (ν_n, ν'_n)).
        """
        if not self.measures_velocity:
            return super().gains(n, times)
        raw, _ = self._raw_gains(n, times)
        return raw.reshape(-1, 2, 2)
