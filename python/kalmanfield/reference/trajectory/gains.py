"""The fuzzy [K95 5–6] and Kalman recursions of the spreads and gains, vectorised over lanes.

Gains are arrays (..., 4) = (xx, xv, vx, vv): x̂ = x̂^e + xx ν + xv ν', x̂' = x̂'^e + vx ν + vv ν'
(ν' = 0 without velocity measurements). Spreads are (..., 3): (P, P', unused) for the fuzzy
filter, (Σ_xx, Σ_xv, Σ_vv) for Kalman.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Spreads:
    """P, Q, R, P', Q', R' (None: no velocity measurements) and the rule."""

    rule: str
    p: float
    q: float
    r: float
    p_vel: float = 0.0
    q_vel: float = 0.0
    r_vel: float | None = None

    @property
    def has_velocity(self) -> bool:
        return self.p_vel > 0 or self.q_vel > 0 or self.r_vel is not None

    def as_rule(self, rule: str) -> Spreads:
        return Spreads(rule, self.p, self.q, self.r, self.p_vel, self.q_vel, self.r_vel)


def _fuzzy_start(m: Spreads, seen_vel):
    seen_vel = np.asarray(seen_vel, dtype=bool)
    shape = seen_vel.shape
    r2, p2 = m.r**2, m.p**2
    p0_sq = r2 * p2 / (r2 + p2)
    gain = np.zeros(shape + (4,))
    gain[..., 0] = p0_sq / r2
    spread = np.zeros(shape + (3,))
    spread[..., 0] = np.sqrt(p0_sq)
    spread[..., 1] = m.p_vel
    if m.r_vel is not None:
        rv2, pv2 = m.r_vel**2, m.p_vel**2
        pv0_sq = pv2 * rv2 / (pv2 + rv2)
        spread[..., 1] = np.where(seen_vel, np.sqrt(pv0_sq), m.p_vel)
        gain[..., 3] = np.where(seen_vel, pv0_sq / rv2, 0.0)
    return spread, gain


def _fuzzy_advance(m: Spreads, spread, tau, seen_pos, seen_vel):
    p, p_vel = spread[..., 0], spread[..., 1]
    q_n = p + p_vel * tau + m.q
    q_vel_n = p_vel + m.q_vel
    r2 = m.r**2
    gain = np.zeros(spread.shape[:-1] + (4,))
    new = np.zeros_like(spread)
    with np.errstate(invalid="ignore", divide="ignore"):
        p_sq = r2 * q_n**2 / (r2 + q_n**2)
        if m.r_vel is None:
            h = p + m.q + m.r + m.q_vel * tau
            p_vel_sq = h**2 * q_vel_n**2 / (h**2 + q_vel_n**2 * tau**2)
            gain[..., 0] = np.where(seen_pos, p_sq / r2, 0.0)
            gain[..., 2] = np.where(seen_pos, p_vel_sq * tau**2 / h**2 / tau, 0.0)
            new[..., 0] = np.where(seen_pos, np.sqrt(p_sq), q_n)
            new[..., 1] = np.where(seen_pos, np.sqrt(p_vel_sq), q_vel_n)
        else:
            rv2 = m.r_vel**2
            p_vel_sq = rv2 * q_vel_n**2 / (rv2 + q_vel_n**2)
            gain[..., 0] = np.where(seen_pos, p_sq / r2, 0.0)
            gain[..., 3] = np.where(seen_vel, p_vel_sq / rv2, 0.0)
            new[..., 0] = np.where(seen_pos, np.sqrt(p_sq), q_n)
            new[..., 1] = np.where(seen_vel, np.sqrt(p_vel_sq), q_vel_n)
    spread[...] = new
    return gain


def _kalman_correct(m: Spreads, spread, seen_pos, seen_vel):
    """Σ ← Σ - K H Σ with the observed rows of H = I; returns K (..., 4)."""
    lanes = spread.shape[:-1]
    gain = np.zeros(lanes + (4,))
    seen_vel = np.asarray(seen_vel, dtype=bool) & (m.r_vel is not None)
    for idx in np.ndindex(*lanes):
        xx, xv, vv = spread[idx]
        cov = np.array([[xx, xv], [xv, vv]])
        rows = [i for i, s in enumerate((seen_pos[idx], seen_vel[idx])) if s]
        if not rows:
            continue
        noise = np.diag([m.r**2, (m.r_vel or 0.0) ** 2])[np.ix_(rows, rows)]
        h = np.eye(2)[rows]
        k = cov @ h.T @ np.linalg.inv(h @ cov @ h.T + noise)
        cov = cov - k @ h @ cov
        spread[idx] = (cov[0, 0], cov[0, 1], cov[1, 1])
        full = np.zeros((2, 2))
        full[:, rows] = k
        gain[idx] = full.ravel()
    return gain


def _kalman_predict(m: Spreads, spread, tau):
    xx, xv, vv = spread[..., 0], spread[..., 1], spread[..., 2]
    out = np.empty_like(spread)
    out[..., 0] = xx + 2 * tau * xv + tau**2 * vv + m.q**2
    out[..., 1] = xv + tau * vv
    out[..., 2] = vv + m.q_vel**2
    return out


def start(m: Spreads, seen_vel):
    """(spread, gain) at a segment's first sample (position observed)."""
    seen_vel = np.asarray(seen_vel, dtype=bool)
    if m.rule == "fuzzy":
        return _fuzzy_start(m, seen_vel)
    spread = np.zeros(seen_vel.shape + (3,))
    spread[..., 0] = m.p**2
    spread[..., 2] = m.p_vel**2
    gain = _kalman_correct(m, spread, np.ones(seen_vel.shape, dtype=bool), seen_vel)
    return spread, gain


def advance(m: Spreads, spread, tau, seen_pos, seen_vel):
    """Gains of a step after τ (spread updated in place)."""
    seen_pos = np.asarray(seen_pos, dtype=bool)
    seen_vel = np.asarray(seen_vel, dtype=bool)
    if m.rule == "fuzzy":
        return _fuzzy_advance(m, spread, tau, seen_pos, seen_vel)
    spread[...] = _kalman_predict(m, spread, tau)
    return _kalman_correct(m, spread, seen_pos, seen_vel)


def gain_sequence(m: Spreads, times) -> np.ndarray:
    """(n, 4) gains of a segment with every sample observed at `times`."""
    times = np.asarray(times, dtype=float)
    spread, g0 = start(m, np.ones((), dtype=bool))
    out = [g0]
    for n in range(1, len(times)):
        tau = times[n] - times[n - 1]
        out.append(advance(m, spread, tau, np.ones((), bool), np.ones((), bool)))
    return np.array(out).reshape(len(times), 4)
