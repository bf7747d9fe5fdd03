"""The change detectors that restart the filter [K95 8–10], one series at a time.

- ``fuzzy``: Δ_n = z_n - x̂^e_n of the fuzzy filter of the same spreads,
  s_n = s_{n-1} + γ_n(Δ_n² - s_{n-1}), D_n = D_{n-1} + γ_n((Q_n + R)² - D_{n-1}); alarm when
  s_n > -D_n ln(1 - μ). γ_n: the 1-D fuzzy filter with measurement spread
  R_Δ = P_{n-1} + P'_{n-1}τ_n + R (P_{n-1} + R with velocity measurements), process spread 2Q,
  γ = 1 at a segment's first residual.
- ``chi2``: the sum of the last W squared normalised innovations of a diffuse-start Kalman
  filter against the χ²_W quantile.
- ``cusum``: the two-sided CUSUM of the same innovations with drift k against h.
At an alarm at t_n the filters restart: z_n is the first sample of the estimator's new
segment (and of the fuzzy test's filter); the Kalman filter of chi2/cusum restarts at z_{n+1}.
"""

from __future__ import annotations

import math

import numpy as np

from .cusum import cusum_threshold
from .filtering import SeriesFilter
from .gains import Spreads


class InnovationFilter:
    """The Kalman filter of the detectors, started without prior (diffuse)."""

    def __init__(self, m: Spreads):
        self.m = m
        self.t_last = math.nan
        self.restart()

    def restart(self):
        self.phase = "empty"
        self.x = np.full(2, np.nan)
        self.cov = np.zeros((2, 2))

    def _f(self, tau):
        return np.array([[1.0, tau], [0.0, 1.0]])

    def _qd(self):
        return np.diag([self.m.q**2, self.m.q_vel**2])

    def innovation(self, t, z):
        if self.phase != "proper" or math.isnan(z):
            return None
        f = self._f(t - self.t_last)
        pred = f @ self.cov @ f.T + self._qd()
        return (z - (f @ self.x)[0]) / math.sqrt(pred[0, 0] + self.m.r**2)

    def _update(self, z, zv):
        rows, values, noise = [], [], []
        if not math.isnan(z):
            rows, values, noise = [0], [z], [self.m.r**2]
        if self.m.r_vel is not None and not math.isnan(zv):
            rows, values, noise = rows + [1], values + [zv], noise + [self.m.r_vel**2]
        if not rows:
            return
        h = np.eye(2)[rows]
        k = self.cov @ h.T @ np.linalg.inv(h @ self.cov @ h.T + np.diag(noise))
        self.x = self.x + k @ (np.array(values) - h @ self.x)
        self.cov = self.cov - k @ h @ self.cov

    def step(self, t, z, zv=math.nan):
        m, r2 = self.m, self.m.r**2
        seen_vel = m.r_vel is not None and not math.isnan(zv)
        if self.phase == "empty" and not math.isnan(z):
            if not m.has_velocity:
                self.x, self.cov, self.phase = np.array([z, 0.0]), np.diag([r2, 0.0]), "proper"
            elif seen_vel:
                self.x, self.cov = np.array([z, zv]), np.diag([r2, m.r_vel**2])
                self.phase = "proper"
            else:
                self.anchor, self.drift, self.phase = (z, t), np.zeros((2, 2)), "half"
        elif self.phase == "half":
            f = self._f(t - self.t_last)
            self.drift = f @ self.drift @ f.T + self._qd()
            if not math.isnan(z):
                za, ta = self.anchor
                span = t - ta
                e = self.drift
                vv = (2 * r2 + e[0, 0] - 2 * span * e[0, 1] + span**2 * e[1, 1]) / span**2
                self.x = np.array([z, (z - za) / span])
                self.cov = np.array([[r2, r2 / span], [r2 / span, vv]])
                self.phase = "proper"
                if seen_vel:
                    self._update(math.nan, zv)
        elif self.phase == "proper":
            f = self._f(t - self.t_last)
            self.x = f @ self.x
            self.cov = f @ self.cov @ f.T + self._qd()
            self._update(z, zv)
        self.t_last = t


class _Fuzzy:
    def __init__(self, m: Spreads, confidence: float):
        self.m = m
        self.threshold = -math.log1p(-confidence)
        self.filter = SeriesFilter(m.as_rule("fuzzy"))
        self.restart()

    def restart(self):
        self.filter.restart()
        self.s = self.d = self.p_diff = 0.0
        self.tested = False

    def assess(self, t, z):
        pred = self.filter.prediction(t)
        if pred is None or math.isnan(z):
            return None
        xe, _, tau = pred
        p, p_vel = self.filter.spread[0], self.filter.spread[1]
        q_n = p + p_vel * tau + self.m.q
        r_delta = p + self.m.r if self.m.r_vel is not None else p + p_vel * tau + self.m.r
        if self.tested:
            q_diff = self.p_diff + 2 * self.m.q
            p_sq = r_delta**2 * q_diff**2 / (r_delta**2 + q_diff**2)
            gamma, p_diff = p_sq / r_delta**2, math.sqrt(p_sq)
        else:
            gamma, p_diff = 1.0, r_delta
        s = self.s + gamma * ((z - xe) ** 2 - self.s)
        d = self.d + gamma * ((q_n + self.m.r) ** 2 - self.d)
        return s / (d * self.threshold), (s, d, p_diff)

    def commit(self, t, z, zv, pending):
        self.filter.step(t, z, zv)
        if pending is not None:
            self.s, self.d, self.p_diff = pending
            self.tested = True
        elif self.tested:
            self.p_diff += 2 * self.m.q


class _Chi2:
    def __init__(self, m: Spreads, confidence: float, window: int):
        from scipy import stats  # the test extra

        self.m, self.window = m, window
        self.threshold = stats.chi2.ppf(confidence, window)
        self.filter = InnovationFilter(m)
        self.restart()

    def restart(self) -> None:
        self.filter.restart()
        self.squares: list[float] = []

    def assess(self, t, z):
        u = self.filter.innovation(t, z)
        if u is None:
            return None
        window = self.squares[len(self.squares) + 1 - self.window :] + [u * u]
        if len(window) < self.window:
            return math.nan, u * u
        return math.fsum(window) / self.threshold, u * u

    def commit(self, t, z, zv, pending):
        self.filter.step(t, z, zv)
        if pending is not None:
            self.squares = (self.squares + [pending])[-self.window :]


class _Cusum:
    def __init__(self, m: Spreads, confidence: float, drift: float):
        self.m, self.drift = m, drift
        self.threshold = cusum_threshold(confidence, drift)
        self.filter = InnovationFilter(m)
        self.restart()

    def restart(self):
        self.filter.restart()
        self.up = self.down = 0.0

    def assess(self, t, z):
        u = self.filter.innovation(t, z)
        if u is None:
            return None
        up = max(0.0, self.up + u - self.drift)
        down = max(0.0, self.down - u - self.drift)
        return max(up, down) / self.threshold, (up, down)

    def commit(self, t, z, zv, pending):
        self.filter.step(t, z, zv)
        if pending is not None:
            self.up, self.down = pending


def detect(
    m: Spreads, method: str, confidence: float, z, times=None, z_vel=None, window=5, drift=0.5
):
    """(positions, velocities, alarms, statistic/threshold) of one series."""
    z = np.asarray(z, dtype=float)
    t = np.arange(len(z), dtype=float) if times is None else np.asarray(times, dtype=float)
    zv = np.full(len(z), np.nan) if z_vel is None else np.asarray(z_vel, dtype=float)
    test: _Fuzzy | _Chi2 | _Cusum
    if method == "fuzzy":
        test = _Fuzzy(m, confidence)
    elif method == "chi2":
        test = _Chi2(m, confidence, window)
    else:
        test = _Cusum(m, confidence, drift)
    estimator = SeriesFilter(m)
    out = np.full((len(z), 4), np.nan)
    for n in range(len(z)):
        a = test.assess(t[n], z[n])
        ratio = math.nan if a is None else a[0]
        if ratio > 1:
            estimator.restart()
            test.restart()
            if method == "fuzzy":
                test.commit(t[n], z[n], zv[n], None)
            else:  # the Kalman filter of chi2/cusum restarts from the next sample
                test.commit(t[n], math.nan, math.nan, None)
        else:
            test.commit(t[n], z[n], zv[n], None if a is None else a[1])
        x, v = estimator.step(t[n], z[n], zv[n])
        out[n] = x, v, ratio > 1, ratio
    return out[:, 0], out[:, 1], out[:, 2].astype(bool), out[:, 3]
