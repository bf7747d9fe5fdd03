"""Shared inputs of the trajectory tests: models, seeded series with and without jumps, and an
independent textbook Kalman filter (plain matrices)."""

from __future__ import annotations

import numpy as np

from kalmanfield import FuzzyFilter, KalmanFilterCV
from kalmanfield.reference import trajectory as ref

#: (P, Q, R, P_vel, Q_vel, R_vel) settings covering the 1-D filter, the position–velocity
#: filter and the variant with velocity measurements
SETTINGS = [
    (1.0, 1.0, 1.0, 0.0, 0.0, None),
    (1.0, 1.0, 1.0, 1.0, 1.0, None),
    (2.0, 0.1, 1.0, 2.0, 0.1, None),
    (0.5, 0.3, 2.0, 0.0, 0.2, None),
    (1.0, 0.5, 1.0, 1.0, 0.3, 0.7),
]

CLASSES = {"fuzzy": FuzzyFilter, "kalman": KalmanFilterCV}


def make(rule, setting):
    """(API filter, twin spreads) of a rule and a setting."""
    p, q, r, pv, qv, rv = setting
    return CLASSES[rule](p, q, r, pv, qv, rv), ref.Spreads(rule, p, q, r, pv, qv, rv)


def random_walks(n_series, n, seed, q=0.3, q_vel=0.05, r=1.0):
    """(z, z_vel, x, x_vel): constant-velocity trajectories and their noisy samples."""
    rng = np.random.default_rng(seed)
    vel = rng.normal(0, 1, (n_series, 1)) + np.cumsum(rng.normal(0, q_vel, (n_series, n)), 1)
    x = np.cumsum(vel, axis=1) + np.cumsum(rng.normal(0, q, (n_series, n)), 1)
    z = x + rng.normal(0, r, x.shape)
    z_vel = vel + rng.normal(0, r, x.shape)
    return z, z_vel, x, vel


def textbook_kalman(z, times, x0, v0, P, Q, R, P_vel, Q_vel, z_vel=None, R_vel=None):
    """The Kalman filter with matrices F, H, Q, R written out (no shortcut): started at
    (x0, v0) with covariance diag(P², P_vel²), updated with z_0, then predict/update."""
    x = np.array([x0, v0], dtype=float)
    cov = np.diag([P**2, P_vel**2])
    measured = z_vel is not None
    h = np.eye(2) if measured else np.array([[1.0, 0.0]])
    noise = np.diag([R**2, R_vel**2]) if measured else np.array([[R**2]])
    out = []
    for n in range(len(z)):
        if n > 0:
            tau = times[n] - times[n - 1]
            f = np.array([[1.0, tau], [0.0, 1.0]])
            x = f @ x
            cov = f @ cov @ f.T + np.diag([Q**2, Q_vel**2])
        meas = np.array([z[n], z_vel[n]]) if measured else np.array([z[n]])
        s = h @ cov @ h.T + noise
        k = cov @ h.T @ np.linalg.inv(s)
        x = x + k @ (meas - h @ x)
        cov = (np.eye(2) - k @ h) @ cov
        out.append(x.copy())
    return np.array(out)
