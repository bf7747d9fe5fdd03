"""Plain-NumPy twin of the search-recurrent tracker (``rust/src/template/tracker.rs``): the
same rules (window, collapse, re-acquisition, template update) written out directly, the
Kalman filter in its textbook form (P = (I − KH)P⁻) with F and Q written here, the searches
by the brute-force :func:`.matching.surface`. For small frames.

Rules (the method page *Template tracker* states them for users):

- first frame: searched around the initial position without a prediction;
- window: the positions within ± gate·√S of the predicted top-left (S = H P⁻ Hᵀ + R), to
  whole pixels plus one on each side, plus the template, cut to the frame;
- validation gate: the in-window peak is the highest score among the positions p with
  νᵀ S⁻¹ ν ≤ gate², ν = p − ẑ shrunk by ½ per axis towards 0 (ẑ the predicted top-left);
- manoeuvre (held hypothesis): when the in-gate peak collapses (not on the first frame),
  the gate of a second prediction is searched — the last estimated position with its
  covariance, velocity and acceleration restarted from the prior (zero mean, prior
  variances), one step of F; its gated peak, when its score is at least ρ̄, is the
  measurement and that prediction the one updated (its window reported);
- collapse: no searchable position, or the in-window NCC peak below collapse·ρ̄, ρ̄ the running
  mean of accepted scores (ρ̄ ← 0.9 ρ̄ + 0.1 s; the first accepted score starts it);
- re-acquisition: after a collapse, the whole-frame peak is accepted when its score is at
  least collapse·ρ̄ (0 before any accepted score) and (peak − median)/(1.4826·MAD) ≥
  reacquire_z over the 64 × 64-point subsample (default √(2 ln M) + 1, M positions); the
  state restarts there with zero velocity and the initial covariance; otherwise the frame is
  coasted: the prediction, with the prior variances of the velocity (and acceleration) added
  to theirs (lost lock);
- template update (rate α): after an accepted in-window measurement whose score is at least
  ρ̄ (before its update), template ← (1 − α)·template + α·patch at the rounded position (if
  the patch lies in the window and has no NaN; kept if the blend is constant).
"""

from __future__ import annotations

import numpy as np

from .matching import refine_peak, surface

REFERENCE_WEIGHT = 0.1
SPREAD_SAMPLES = 64


def motion_model(model: str, process_std: float, dt: float, measurement_std: float):
    """(F, Q, H, R) per axis x, y: continuous white-noise jerk (``"acceleration"``) or
    acceleration (``"velocity"``) of power spectral density q = process_std²."""
    q = process_std**2
    t = dt
    if model == "acceleration":
        f1 = np.array([[1, t, t * t / 2], [0, 1, t], [0, 0, 1]])
        q1 = q * np.array(
            [
                [t**5 / 20, t**4 / 8, t**3 / 6],
                [t**4 / 8, t**3 / 3, t**2 / 2],
                [t**3 / 6, t**2 / 2, t],
            ]
        )
    else:
        f1 = np.array([[1, t], [0, 1]])
        q1 = q * np.array([[t**3 / 3, t**2 / 2], [t**2 / 2, t]])
    d = len(f1)
    f = np.zeros((2 * d, 2 * d))
    qm = np.zeros((2 * d, 2 * d))
    for a in range(2):
        f[a * d : (a + 1) * d, a * d : (a + 1) * d] = f1
        qm[a * d : (a + 1) * d, a * d : (a + 1) * d] = q1
    h = np.zeros((2, 2 * d))
    h[0, 0] = h[1, d] = 1.0
    return f, qm, h, np.eye(2) * measurement_std**2


def distinctness(s: np.ndarray, score: float) -> float:
    """(score − median) / (1.4826·MAD) over the 64 × 64-point subsample of the surface."""
    rows, cols = s.shape
    sub = s[:: max(rows // SPREAD_SAMPLES, 1), :: max(cols // SPREAD_SAMPLES, 1)]
    sub = sub[:SPREAD_SAMPLES, :SPREAD_SAMPLES]
    sub = sub[~np.isnan(sub)]
    if sub.size == 0:
        return 0.0
    median = float(np.median(sub))
    mad = float(np.median(np.abs(sub - median)))
    if mad > 0:
        return (score - median) / (1.4826 * mad)
    return np.inf if score > median else 0.0


class TwinTracker:
    """The tracker over a list of templates (positions: top-left in the first frame)."""

    def __init__(
        self,
        templates,
        positions,
        *,
        model="acceleration",
        process_std=0.1,
        measurement_std=1.0,
        dt=1.0,
        gate=3.0,
        initial_std=None,
        collapse=0.5,
        reacquire_z=None,
        update_template=None,
        subpixel=True,
    ):
        self.f, self.q, self.h, self.r = motion_model(model, process_std, dt, measurement_std)
        d = self.f.shape[0] // 2
        if initial_std is None:
            initial_std = [measurement_std, 5.0 / dt, 1.0 / dt**2][:d]
        self.p0 = np.diag(np.tile(np.asarray(initial_std, float) ** 2, 2))
        self.d = d
        self.gate, self.collapse, self.reacquire_z = gate, collapse, reacquire_z
        self.alpha, self.subpixel = update_template, subpixel
        self.templates = [np.asarray(t, dtype=np.float64) for t in templates]
        self.means = [self._start(x, y) for x, y in positions]
        self.covs = [self.p0.copy() for _ in positions]
        self.reference: list[float | None] = [None] * len(self.templates)
        self.frames = 0

    def _start(self, x, y):
        m = np.zeros(2 * self.d)
        m[0], m[self.d] = x, y
        return m

    def _peak(self, frame, template, window, gate=None):
        """The (gated) peak of the surface over `window`; `gate` = (ẑ, S)."""
        s = surface(frame, template, window, "ncc")
        candidates = s.copy()
        if gate is not None:
            centre, cov = gate
            ys, xs = np.indices(s.shape)
            nu = np.stack([xs + window[0] - centre[0], ys + window[1] - centre[1]], axis=-1)
            nu = np.sign(nu) * np.maximum(np.abs(nu) - 0.5, 0.0)
            q = np.einsum("...i,ij,...j->...", nu, np.linalg.inv(cov), nu)
            candidates[q > self.gate**2] = np.nan
        if np.isnan(candidates).all():
            return None, s
        iy, ix = divmod(int(np.nanargmax(candidates)), s.shape[1])
        dx, dy = refine_peak(s, ix, iy) if self.subpixel else (0.0, 0.0)
        x0, y0 = window[0], window[1]
        return (x0 + ix + dx, y0 + iy + dy, float(s[iy, ix])), s

    def _window(self, mean, cov, shape, tshape):
        height, width = shape
        h, w = tshape
        centre = self.h @ mean
        s = self.h @ cov @ self.h.T + self.r
        half = self.gate * np.sqrt(np.diag(s))
        x0 = np.floor(centre[0] - half[0]) - 1
        x1 = np.ceil(centre[0] + half[0]) + 1 + w
        y0 = np.floor(centre[1] - half[1]) - 1
        y1 = np.ceil(centre[1] + half[1]) + 1 + h
        x0, x1 = (int(np.clip(v, 0, width)) for v in (x0, x1))
        y0, y1 = (int(np.clip(v, 0, height)) for v in (y0, y1))
        if x0 >= x1 or y0 >= y1:
            return None
        return x0, y0, x1, y1

    def _search(self, frame, template, mean, cov):
        """(window, gated peak or None) of the prediction (mean, cov)."""
        h, w = template.shape
        window = self._window(mean, cov, frame.shape, template.shape)
        if window is None or window[3] - window[1] < h or window[2] - window[0] < w:
            return window, None
        gate = (self.h @ mean, self.h @ cov @ self.h.T + self.r)
        return window, self._peak(frame, template, window, gate)[0]

    def _held(self, mean, cov):
        """The held hypothesis' prediction: the position and its covariance kept, velocity and
        acceleration restarted from the prior, one step of F."""
        positions = np.arange(len(mean)) % self.d == 0
        m = np.where(positions, mean, 0.0)
        p = np.where(np.outer(positions, positions), cov, self.p0)
        return self.f @ m, self.f @ p @ self.f.T + self.q

    def update(self, frame):
        """One frame: per template a dict (mean, cov, score, measurement, window, collapsed,
        reacquired)."""
        frame = np.asarray(frame)
        out = []
        for k, t in enumerate(self.templates):
            h, w = t.shape
            if self.frames == 0:
                mean, cov = self.means[k], self.covs[k]
            else:
                mean = self.f @ self.means[k]
                cov = self.f @ self.covs[k] @ self.f.T + self.q
            window, found = self._search(frame, t, mean, cov)
            ref = self.reference[k]
            collapsed = found is None or (ref is not None and found[2] < self.collapse * ref)
            if collapsed and self.frames > 0:
                held_mean, held_cov = self._held(self.means[k], self.covs[k])
                held_window, held = self._search(frame, t, held_mean, held_cov)
                if held is not None and ref is not None and held[2] >= ref:
                    mean, cov, window, found = held_mean, held_cov, held_window, held
                    collapsed = False
            step = dict(
                score=np.nan if found is None else found[2],
                window=window,
                collapsed=collapsed,
                reacquired=False,
                measurement=None,
            )
            if not collapsed:
                assert found is not None
                x, y, score = found
                z = np.array([x, y])
                s = self.h @ cov @ self.h.T + self.r
                gain = cov @ self.h.T @ np.linalg.inv(s)
                mean = mean + gain @ (z - self.h @ mean)
                cov = (np.eye(len(mean)) - gain @ self.h) @ cov
                if self.alpha is not None and (ref is None or score >= ref):
                    self._update_template(k, frame, x, y, window)
                self.reference[k] = score if ref is None else 0.9 * ref + 0.1 * score
                step["measurement"] = (x, y)
            else:
                best, s = self._peak(frame, t, (0, 0, frame.shape[1], frame.shape[0]))
                floor = self.collapse * (ref if ref is not None else 0.0)
                z = self.reacquire_z
                if z is None:
                    z = np.sqrt(2 * np.log(s.size)) + 1.0
                if best is not None and best[2] >= floor and distinctness(s, best[2]) - z >= 0.0:
                    mean, cov = self._start(best[0], best[1]), self.p0.copy()
                    step["reacquired"] = True
                    step["measurement"] = (best[0], best[1])
                else:
                    derivatives = np.arange(len(mean)) % self.d != 0
                    cov = cov + np.diag(np.where(derivatives, np.diag(self.p0), 0.0))
            self.means[k], self.covs[k] = mean, cov
            step["mean"], step["cov"] = mean.copy(), cov.copy()
            out.append(step)
        self.frames += 1
        return out

    def _update_template(self, k, frame, x, y, window):
        t = self.templates[k]
        h, w = t.shape
        x0, y0 = int(np.floor(x + 0.5)), int(np.floor(y + 0.5))
        inside = x0 >= window[0] and y0 >= window[1]
        inside = inside and x0 + w <= window[2] and y0 + h <= window[3]
        if not inside:
            return
        patch = np.asarray(frame[y0 : y0 + h, x0 : x0 + w], dtype=np.float64)
        if np.isnan(patch).any():
            return
        blend = (1 - self.alpha) * t + self.alpha * patch
        if not np.all(blend == blend.flat[0]):
            self.templates[k] = blend
