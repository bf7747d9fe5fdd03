"""The filter of the method page *Fuzzy filter*, §4.1–4.3 [K95 5–7]: one series sample by
sample (:class:`SeriesFilter`), and all series at once (:func:`filter_batch`, vectorised over
series when the times are shared and no sample is missing — the NumPy floor the Rust kernel is
benchmarked against).

Segment start: a segment begins at the first observed sample; during its first three samples
the start x̄_0, x̄'_0 is refitted by least squares on the observed samples so far and the
recursion rerun from the segment's first sample (the estimate at t_n uses z_0..z_n only);
from the third sample on the recursion continues. A missing sample (NaN) is predicted.
"""

from __future__ import annotations

import math

import numpy as np

from .gains import Spreads, advance, gain_sequence, start


def least_squares_start(has_velocity: bool, t, z) -> tuple[float, float]:
    """(x̄_0, x̄'_0): a line in time through the observed samples (value at t[0], slope), or
    their mean and 0 without a velocity or with one observed sample."""
    t, z = np.asarray(t, dtype=float), np.asarray(z, dtype=float)
    seen = ~np.isnan(z)
    dt, zs = t[seen] - t[0], z[seen]
    if not has_velocity or len(zs) < 2:
        return float(zs.mean()), 0.0
    slope, intercept = np.polyfit(dt, zs, 1)
    return float(intercept), float(slope)


def _correct(m: Spreads, xe, ve, g, nu, nu_v):
    return xe + g[0] * nu + g[1] * nu_v, ve + g[2] * nu + g[3] * nu_v


class SeriesFilter:
    """One series' filter (the twin of the Rust ``SeriesFilter``)."""

    def __init__(self, m: Spreads):
        self.m = m
        self.t_last = math.nan
        self.restart()

    def restart(self) -> None:
        """The next observed sample begins a new segment."""
        self.started = False
        self.warm: list[tuple[float, float, float]] = []
        self.x = self.v = math.nan
        self.spread = np.zeros(3)

    def prediction(self, t: float):
        """(x̂^e, x̂'^e, τ) or None before a segment has begun."""
        if not self.started:
            return None
        tau = t - self.t_last
        return self.x + self.v * tau, self.v, tau

    def _innovations(self, xe, ve, z, zv):
        seen_pos = not math.isnan(z)
        seen_vel = self.m.r_vel is not None and not math.isnan(zv)
        return (z - xe if seen_pos else 0.0), (zv - ve if seen_vel else 0.0), seen_pos, seen_vel

    def _advance(self, tau, z, zv):
        xe, ve = self.x + self.v * tau, self.v
        nu, nu_v, sp, sv = self._innovations(xe, ve, z, zv)
        g = advance(self.m, self.spread, tau, sp, sv)
        self.x, self.v = _correct(self.m, xe, ve, g, nu, nu_v)

    def _warm_up(self):
        ts = [w[0] for w in self.warm]
        zs = [w[1] for w in self.warm]
        x0, v0 = least_squares_start(self.m.has_velocity, ts, zs)
        t0, z0, zv0 = self.warm[0]
        nu, nu_v, _, sv = self._innovations(x0, v0, z0, zv0)
        spread, g = start(self.m, sv)
        self.spread = np.array(spread, dtype=float).reshape(3)
        self.x, self.v = _correct(self.m, x0, v0, np.asarray(g).reshape(4), nu, nu_v)
        for (ta, _, _), (tb, zb, zvb) in zip(self.warm, self.warm[1:]):
            self._advance(tb - ta, zb, zvb)

    def step(self, t: float, z: float, zv: float = math.nan) -> tuple[float, float]:
        if not self.t_last < t and not math.isnan(self.t_last):
            raise ValueError("times must increase strictly")
        if not self.started:
            if not math.isnan(z):
                self.started = True
                self.warm = [(t, z, zv)]
                self._warm_up()
        elif len(self.warm) < 3:
            self.warm.append((t, z, zv))
            self._warm_up()
        else:
            self._advance(t - self.t_last, z, zv)
        self.t_last = t
        return self.x, self.v


def _times_of(times, shape):
    if times is None:
        return np.broadcast_to(np.arange(shape[1], dtype=float), shape)
    return np.broadcast_to(np.asarray(times, dtype=float), shape)


def filter_series(m: Spreads, z, times=None, z_vel=None):
    """(positions, velocities) of one series, sample by sample."""
    z = np.asarray(z, dtype=float)
    t = _times_of(times, (1, len(z)))[0]
    zv = np.full(len(z), np.nan) if z_vel is None else np.asarray(z_vel, dtype=float)
    f = SeriesFilter(m)
    out = np.array([f.step(t[n], z[n], zv[n]) for n in range(len(z))]).reshape(len(z), 2)
    return out[:, 0], out[:, 1]


def filter_batch(m: Spreads, z, times=None, z_vel=None):
    """(positions, velocities) of every series of the (series, samples) array `z`.

    With times shared by all series (None or 1-D) and no missing sample, the gains are
    computed once and the recursion runs over all series at once, sample-major (the best
    vectorised NumPy version); otherwise series by series.
    """
    z = np.asarray(z, dtype=float)
    shared = times is None or np.ndim(times) == 1
    missing = np.isnan(z).any() or (z_vel is not None and np.isnan(z_vel).any())
    if not shared or missing:
        t = _times_of(times, z.shape)
        pairs = [
            filter_series(m, z[s], t[s], None if z_vel is None else z_vel[s])
            for s in range(z.shape[0])
        ]
        return np.array([p for p, _ in pairs]), np.array([v for _, v in pairs])
    return _filter_shared(m, z, _times_of(times, (1, z.shape[1]))[0], z_vel)


def _run(gains, t, z, zv, x0, v0, upto):
    """The recursion (7) over samples 0..upto of all series from the start (x0, v0)."""
    nu_v = 0.0 if zv is None else zv[0] - v0
    g = gains[0]
    x = x0 + g[0] * (z[0] - x0) + g[1] * nu_v
    v = v0 + g[2] * (z[0] - x0) + g[3] * nu_v
    for k in range(1, upto + 1):
        x, v = _step(gains[k], t[k] - t[k - 1], x, v, z[k], None if zv is None else zv[k])
    return x, v


def _step(g, tau, x, v, z, zv):
    xe = x + v * tau
    nu = z - xe
    nu_v = 0.0 if zv is None else zv - v
    return xe + g[0] * nu + g[1] * nu_v, v + g[2] * nu + g[3] * nu_v


def _filter_shared(m: Spreads, z, t, z_vel):
    n_series, n = z.shape
    gains = gain_sequence(m, t)
    zt = np.ascontiguousarray(z.T)
    zvt = None if z_vel is None else np.ascontiguousarray(np.asarray(z_vel, dtype=float).T)
    pos = np.empty((n, n_series))
    vel = np.empty((n, n_series))
    for k in range(min(3, n)):  # the warm-up: the least-squares start on samples 0..k, rerun
        dt = t[: k + 1] - t[0]
        mean_t, mean_z = dt.mean(), zt[: k + 1].mean(axis=0)
        if m.has_velocity and k > 0:
            slope = ((dt - mean_t)[:, None] * (zt[: k + 1] - mean_z)).sum(axis=0) / (
                (dt - mean_t) ** 2
            ).sum()
            x0, v0 = mean_z - slope * mean_t, slope
        else:
            x0, v0 = mean_z, np.zeros(n_series)
        pos[k], vel[k] = _run(gains, t, zt, zvt, x0, v0, k)
    x, v = pos[min(3, n) - 1].copy(), vel[min(3, n) - 1].copy()
    for k in range(3, n):
        x, v = _step(gains[k], t[k] - t[k - 1], x, v, zt[k], None if zvt is None else zvt[k])
        pos[k], vel[k] = x, v
    return pos.T, vel.T
