"""The possibility-theory ("fuzzy") filter of a parameter's trajectory (method page *Fuzzy
filter*, §4.1; [K95 5–7])."""

from __future__ import annotations

from .motion_filter import MotionFilter


class FuzzyFilter(MotionFilter):
    """Possibility-theory analogue of the position–velocity Kalman filter [K95].

    Model per scalar parameter: x_n = x_{n-1} + x'_{n-1}τ_n + w_n, x'_n = x'_{n-1} + w'_n,
    z_n = x_n + v_n, with membership functions exp(-a²/s²) of spreads P, P' (initial state), Q,
    Q' (process) and R (measurements). The estimates are the maxima of the posterior
    memberships: the Kalman form x̂_n = x̂^e_n + α_n(z_n - x̂^e_n),
    x̂'_n = x̂'^e_n + β_n(z_n - x̂^e_n)/τ_n with the fuzzy gains [K95 6].

    Parameters
    ----------
    P, Q, R : float
        Positive spreads of the initial position, of the position noise and of the
        measurements (at most 1e100).
    P_vel, Q_vel : float, optional
        Non-negative spreads of the initial velocity and of the velocity noise;
        ``P_vel = Q_vel = 0`` (default) is the 1-D filter (no velocity: x̂' ≡ 0).
    R_vel : float, optional
        Spread of velocity measurements z'_n = x'_n + v'_n; given, it selects the variant
        with velocity measurements [K95 end] (pass them as ``velocity=``).

    Raises
    ------
    ValueError
        A spread that is not finite, negative (P, Q, R, R_vel: not positive) or above 1e100.
    TypeError
        A spread that is not a real number.

    See Also
    --------
    KalmanFilterCV : The Kalman filter of the same model.
    ChangeDetector : Restarts the filter where the trajectory's model jumps.

    Notes
    -----
    The gains are §4.1 of the method page *Fuzzy filter* (:doc:`/methods/fuzzy_filter`);
    the segment start (least squares on the first three samples, refitted causally),
    missing samples, irregular times and every choice the source leaves open are §4.3. The
    filter pickles mid-series and resumes exactly.

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield import FuzzyFilter
    >>> f = FuzzyFilter(P=1.0, Q=1.0, R=1.0)
    >>> np.round(f.gains(6)[:, 0], 4)
    array([0.5   , 0.7445, 0.7763, 0.7797, 0.78  , 0.78  ])
    >>> est = f.filter([1.0, 1.2, 0.9, 1.4, 1.1])
    >>> est.position.shape
    (5,)
    """

    _rule = "fuzzy"
