"""NumPy reference of the filters over frames (method page *Sequence filter*, §2.5).

Model: frames x_t (H × W) of the separable (n_t, n_y, n_x) field, observed as z_t = x_t + θ_t,
θ white with variance s. Cov(x_t, x_u) = σ² R_t(t − u) R_y ⊗ R_x; with R_y = U_y M_y U_yᵀ,
R_x = U_x M_x U_xᵀ the mode coefficients U_yᵀ x_t U_x are independent AR(n_t) sequences of
variances λ_ab = σ² μ_a ν_b, observed in white noise of variance s (the transform is
orthogonal). Each mode's state is its last d = max(n_t, lag + 1) values, started from the
stationary covariance λ Toeplitz(R_t)[:d, :d].

1. ``modal_filter``: the exact filter (lag 0) / fixed-lag smoother of a whole sequence, with
   the kernel's rule for missing pixels (a partly missing frame is filled with the predicted
   frame; an all-missing one is a prediction step).
2. ``modal_error_map``: the steady per-pixel error variance.
3. ``fast_filter``: the prediction by the time axis' recursion + the smoothed row filter of
   the prediction error (frame 0 with the field's spatial model, later frames with the
   error model); for n_t ≥ 2 the previous estimate corrected by c·û before the next
   prediction.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh, toeplitz

from ..field.ar_field import axis_ar_coefficients, axis_correlation, beta_tilde_sq, stationary_start
from ..rowfilter.row_filters import scalar_row_filter


def mode_basis(rho, order, sigma, height, width):
    """(U_y, U_x, λ (H × W)) of the spatial axes 1, 2 of a (t, y, x) model."""
    mu, uy = eigh(toeplitz(axis_correlation(rho[1], order[1], np.arange(height))))
    nu, ux = eigh(toeplitz(axis_correlation(rho[2], order[2], np.arange(width))))
    # (the kernel clamps the eigenvalues of each axis at 1e-15 · the largest)
    mu, nu = np.maximum(mu, 1e-15 * mu.max()), np.maximum(nu, 1e-15 * nu.max())
    return uy, ux, sigma**2 * np.outer(mu, nu)


class _Modes:
    """Every mode's Kalman filter over frames, vectorised over the modes."""

    def __init__(self, rho_t, n_t, lam, noise_var, dim):
        self.alpha = np.zeros(dim)
        self.alpha[:n_t] = axis_ar_coefficients(rho_t, n_t)
        self.drive = beta_tilde_sq(rho_t, n_t)
        self.prior_cov = toeplitz(axis_correlation(rho_t, n_t, np.arange(dim)))
        self.lam, self.s, self.dim = lam.ravel(), noise_var, dim
        self.transition = np.eye(dim, k=-1)
        self.transition[0] = self.alpha
        self.mean = np.zeros((self.lam.size, dim))
        self.cov = np.zeros((self.lam.size, dim, dim))

    def predict(self, first):
        if first:
            self.mean[:] = 0.0
            self.cov = self.lam[:, None, None] * self.prior_cov
            return
        f = self.transition
        self.mean = self.mean @ f.T
        self.cov = f @ self.cov @ f.T
        self.cov[:, 0, 0] += self.lam * self.drive

    def update(self, z):
        c0 = self.cov[:, :, 0]
        s = self.cov[:, 0, 0] + self.s
        gain = c0 / s[:, None]
        self.mean += gain * (z - self.mean[:, 0])[:, None]
        self.cov = self.cov - gain[:, :, None] * c0[:, None, :]


def modal_filter(frames, rho, order, sigma, noise_var, lag=0):
    """Estimates of every frame of ``frames`` (F, H, W): filtered (lag 0), or each frame
    smoothed with the ``lag`` newer ones (the last frames with the ones there are)."""
    frames = np.asarray(frames, dtype=float)
    count, height, width = frames.shape
    uy, ux, lam = mode_basis(rho, order, sigma, height, width)
    modes = _Modes(rho[0], order[0], lam, noise_var, max(order[0], lag + 1))

    def element(k):
        return uy @ modes.mean[:, k].reshape(height, width) @ ux.T

    out = np.empty_like(frames)
    for t, z in enumerate(frames):
        modes.predict(t == 0)
        missing = np.isnan(z)
        if not missing.all():
            filled = np.where(missing, element(0), z)
            modes.update((uy.T @ filled @ ux).ravel())
        if t >= lag:
            out[t - lag] = element(lag)
    for k in range(min(lag, count)):
        out[count - 1 - k] = element(k)
    return out


def modal_error_map(rho, order, sigma, noise_var, shape, lag=0, tol=1e-15):
    """The steady per-pixel error variance of the filter (lag 0) or of the fixed-lag smoother,
    from the Riccati recursion of every mode run until its output variance settles."""
    height, width = shape
    uy, ux, lam = mode_basis(rho, order, sigma, height, width)
    dim = max(order[0], lag + 1)
    modes = _Modes(rho[0], order[0], lam, noise_var, dim)
    modes.predict(True)
    modes.update(np.zeros(lam.size))
    last = np.full(lam.size, np.inf)
    for t in range(1, 1_000_000):
        modes.predict(False)
        modes.update(np.zeros(lam.size))
        v = modes.cov[:, lag, lag]
        if t >= dim and np.all(np.abs(v - last) <= tol * v):
            break
        last = v
    return (uy**2) @ v.reshape(height, width) @ (ux**2).T


def fast_filter(frames, rho, order, sigma, noise_var, error_model, smoothing=0.0):
    """The fast filter of ``frames`` (F, H, W); ``error_model`` = (rho, order, sigma) of the
    2-axis model of the steady prediction error; ``smoothing`` = c, the gain of the
    previous estimate's correction x̂_{t−1|t} = x̂_{t−1} + c·û_t (from frame 1 on)."""
    frames = np.asarray(frames, dtype=float)
    coeffs, _ = stationary_start(rho[0], order[0])
    spatial = (rho[1:], order[1:], sigma)
    history: list[np.ndarray] = []
    out = np.empty_like(frames)
    for t, z in enumerate(frames):
        a = coeffs[min(t, order[0])]
        prediction = sum((c * h for c, h in zip(a, history)), np.zeros(z.shape))
        missing = np.isnan(z)
        weights = np.where(missing, 0.0, 1.0 / noise_var) if missing.any() else None
        residual = np.where(missing, 0.0, z - prediction)
        r, n, s = spatial if t == 0 else error_model
        u = scalar_row_filter(residual, r, n, s, noise_var, smooth=True, weights=weights)
        out[t] = prediction + u
        if history and t > 0:
            history[0] = history[0] + smoothing * u
        history = [out[t], *history][: order[0]]
    return out
