"""NumPy reference of the row Kalman filters for images (method page *Row filters*, §2).

Model (§2): z = x + θ on an H×W grid, x the separable AR field of *Random fields* §1.2–1.3 with
(ρ_y, ρ_x), multiplicities (n_y, n_x) and variance σ², θ white with variance s = σ_θ².
Axis 0 = rows = y is the recursion axis; n = n_y.  All functions take ``rho = (ρ_y, ρ_x)``,
``order = (n_y, n_x)``, ``sigma`` and ``noise_var = s``; images may carry a trailing batch
axis (H, W, B) (all filters are linear, the batch is used for exact MSE maps).

Notation:
  R_y, R_x   normalised correlation Toeplitz matrices (§1.1) of the grid axes,
  T_x = σ² R_x (W×W)   = V_x0 of §2.2,
  A_y        n×n companion matrix (first row α_{y,1..n} [P 2.8], ones below),
  q = β̃_y²   so that the row innovation covariance is q T_x (§2.2 [P 3.32]).
Row state at row k: ȳ_k = (x̄_k, x̄_{k-1}, …, x̄_{k-n+1}); transition S = A_y ⊗ I_W; only x̄_k is
observed (H = (I 0 … 0)).

1. Wiener bound (``wiener_error_map``, ``wiener_bound``)
   Cov(x) = σ² R_y ⊗ R_x.  With R_y = U_y Λ_y U_yᵀ, R_x = U_x Λ_x U_xᵀ the posterior covariance of
   the best linear (non-causal) estimator is (U_y⊗U_x) diag(f) (U_y⊗U_x)ᵀ with
   f_ab = σ²λ_a λ_b s / (σ²λ_a λ_b + s): map = (U_y∘U_y) F (U_x∘U_x)ᵀ, mean = mean(F).
   Cost O(H³ + W³).

2. Optimal vector row filter (``vector_row_filter``), §2.1–2.2, computed EXACTLY in the
   eigenbasis of T_x.  Every matrix of the row state space is a Kronecker product with T_x or
   I_W: S = A_y ⊗ I, Q = q e₁e₁ᵀ ⊗ T_x, R = s I, and the exact stationary prior of the first n
   rows is σ² R_y[:n,:n] ⊗ R_x.  With T_x = U_x diag(λ) U_xᵀ the rotation z̄_k → U_xᵀ z̄_k splits
   the nW-dimensional filter into W independent n-dimensional Kalman filters (mode j: process noise
   q λ_j e₁e₁ᵀ, observation noise s, prior λ_j R_y[:n,:n]) — the same filter as the literal
   dense one of §2.2 (checked to ~1e-12, and against batch GLS), with O(W n³) per Riccati
   step instead of O((nW)³) and O(W² + W n²) per row.
   Exact start: rows 1..n form one static state (stack x̄_n..x̄_1) with the exact stationary
   prior, observed one row at a time, so row t ≤ n gets E[x̄_t | z̄_1..z̄_t]; this is §2.2's
   start (row 1 = scalar filter + backward smoother along the row with the x model, rows
   2..n = boundary models of §1.3) written as one Kalman filter.  diag(P) is the true MSE of
   every pixel, edges and first rows included.  smooth=True adds the RTS pass over rows,
   J_k = P_k Sᵀ P_e,k+1⁻¹ per mode; with the exact start the result is the posterior mean
   given the whole image: its error map equals ``wiener_error_map`` (checked to ~1e-13).

3. Quasi-optimal banded-precision row filter (``scalar_row_filter``), §2.3 generalised.
   §2.3's idea: the update is a Wiener estimate E[u | y] of the prediction error
   u = ȳ_k − ŷ_e,k from the innovation y = z̄_k − x̂_e,k; replace the dense covariance P_e,k by
   an AR model along the row and estimate u by a recursion along the row.  Generalisation:
   (a) model the prediction error of the WHOLE state, not only of x̄_k: at column ℓ the vector
       v_ℓ = (u_k(ℓ), u_{k-1}(ℓ), …, u_{k-n+1}(ℓ)) follows a block AR(m) recursion along ℓ
           v_ℓ = Σ_{i=1..min(ℓ,m)} Γ_{ℓ,i} v_{ℓ-i} + ε_ℓ ,   ε_ℓ ~ N(0, D_ℓ),
       Γ_ℓ = C_{ℓ,past} C_{past,past}⁻¹, D_ℓ = C_ℓℓ − Γ_ℓ C_{past,ℓ}, C = entries of the optimal
       filter's P_e,k within m columns of the diagonal ([P 3.11, 3.12, 3.34–3.36]; n = 1,
       m = 1 is exactly [P 3.11–3.17] with the γ_{ℓ+1} fix).  So the older rows in the
       state are corrected by the current innovation through their modelled cross-covariance
       with u_k (the literal scheme never corrects them: +25…+196 % for (2,2)).
   (b) m = max(n_x, 2) by default for n_y ≥ 2, m = 8 for n_y = 1 (``default_ar_order``: with
       one row in the state the loss grows as ρ → 1, +10.7 % for (1,1) at ρ = 0.99 with
       m = 2, +1.4 % with m = 8).  m ≥ n_x is essential (m = n_x − 1 loses up to +40 %, m = 1
       up to +800 %); m = n_x keeps every n_x ≥ 2 case of the target grid within +0.4 % (32×32:
       (2,2) +0.26 %, (1,2) +0.34 %, (3,3) +0.02 %; m = n_x + 1 gains < 0.1 % for a wider
       band), and (1,1) needs m = 2 (m = 1: +3.8 %; m = 2: within ~2 %, worst ρ = 0.95).
   (c) the model covariance M_k equals P_e,k on the block band; its precision
       Λ_k = M_k⁻¹ = L_kᵀ D_k⁻¹ L_k is block-banded: in the interleaved ordering (ℓ, i) ↦ ℓn + i its
       scalar half-bandwidth is b = n(m+1) − 1.  E_M[u | y] = A_k⁻¹ Hᵀ y / s with
       A_k = Λ_k + HᵀH/s, also banded: the Kalman filter + smoother along the row of §2.3
       becomes ONE banded SPD solve (Cholesky factor precomputed).
   (d) numerics: everything is done on the whitened state v' = T v per column, T = L⁻¹,
       L = chol(R_y[:n,:n]) (``row_basis``).  The fit is equivariant under a constant
       per-column transform, so the filter is the same; but the start prior becomes
       I ⊗ T_x instead of R_y[:n,:n] ⊗ T_x (condition number 7e7·7e6 for (4,4), ρ = 0.9: the
       unwhitened version gave O(0.1) errors).  L₀₀ = 1, so x̄_k = v'₀ is still component 0.
   Per row (after the start), with S' = T A_y L:
       prediction   ŷ_e,k = (I_W ⊗ S') ŷ_{k-1}                       n² mult. per pixel
       innovation   y = z̄_k − (ŷ_e,k)₀
       update       ŷ_k = ŷ_e,k + A_k⁻¹ (y ⊗ e₀) / s                  banded solve, O(W n b)
       output       x̂_k = (ŷ_k)₀
   RTS pass over rows (smooth=True), model version of J_k = P_k Sᵀ P_e,k+1⁻¹ with P_k ≈ A_k⁻¹,
   P_e,k+1⁻¹ ≈ Λ_{k+1}:
       ŷˢ_k = ŷ_k + A_k⁻¹ d_k,  d_k = (I_W ⊗ S'ᵀ) Λ_{k+1} (ŷˢ_{k+1} − ŷ_e,k+1)  one solve
       x̂ˢ_k = (ŷˢ_k)₀ ; rows t < n: x̂ˢ_t = (L ŷˢ_n)_{n−t}
   The product by Λ_{k+1} needs no mat-vec: A_{k+1} = Λ_{k+1} + HᵀWH, the forward step solved
   A_{k+1} (ŷ_{k+1} − ŷ_e,k+1) = HᵀW(z̄_{k+1} − H ŷ_e,k+1) and the RTS step k+1 solved
   A_{k+1} (ŷˢ_{k+1} − ŷ_{k+1}) = d_{k+1} (d_H = 0), so
       Λ_{k+1} (ŷˢ_{k+1} − ŷ_e,k+1) = d_{k+1} + HᵀW (z̄_{k+1} − H ŷˢ_{k+1})      (H = e₀ per column).
   Start (rows t = 1..n, exact when m ≥ n_x, because R_x⁻¹ has half-bandwidth n_x under the
   stationary start of §1.3): Λ_0 = fit of (I ⊗ T_x) (= exact precision),
       A_t = Λ_0 + Σ_{j≤t} I_W ⊗ h_j h_jᵀ / s,   ŷ_t = A_t⁻¹ Σ_{j≤t} z̄_j ⊗ h_j / s,
       h_j = row n−j of L,
       x̂_t = (L ŷ_t)_{n−t}.
   Precomputation, once per (model, s, W, H):
     * eigendecomposition of T_x: O(W³) (symmetric Toeplitz); modes="ends": of a row of
       W' < W points only, its band giving the first and last W'/2 columns and the Fourier
       modes' (``toeplitz_band``) the columns in between (``ends_band``), O(W'³);
     * modal Riccati (``modal_riccati``): P_e,k per mode, O(W n³) per row;
     * band blocks C_d(ℓ) = Cov(v_ℓ, v_{ℓ+d}) = Σ_j U_x[ℓ,j] U_x[ℓ+d,j] T P_e,k,j Tᵀ, d = 0..m:
       O(W² n² m) per row (``prediction_band``);
     * block regressions (``markov_precision``): W solves of size ≤ nm, O(W (nm)³);
     * banded Cholesky of A_k (``banded_cholesky``): O(W n b²).
     P_e,k is NOT settled after a few rows for high multiplicity (weakly observed modes of the
     older rows keep drifting), and using the steady-state model from row n+1 on costs up to
     +3.7 % causal / +11 % smoothed for (4,4) on 32×32.  So the model is refitted whenever
     the band has drifted by > tol (default 1e-3, relative to max|C_0|) from the one it was
     fitted to, and frozen once the band has settled (``settled``: the geometric tail of the
     row-to-row changes < tol; at most MAX_ROW_MODELS models).  (Until 2026-11-26 it froze
     at the first row changing by < tol, which at ρ = 0.999 stopped far from the limit.)
     The transient lasts ~10–55 rows on the issue's grid.  Memory: the Λ_k
     and Cholesky factors of the transient rows (needed again by the RTS pass), each
     O(W n b).  Per-row work afterwards: O(W n b) = O(W n² m) (≈ 4n(b+1) flops per pixel for
     the forward pass, twice that with smoothing).

   Measured (exact MSEs, 64×64, σ_x² = 1, ρ_x = ρ_y ∈ {0.5, 0.8, 0.9, 0.95}, σ_x²/σ_θ² ∈
   {0.1, 1, 10}, (n_y, n_x) ∈ {(1,1)…(4,4), (1,2), (2,1)}, defaults m = n_x + 1, tol = 1e-3):
   causal loss vs the optimal row filter ≤ +2.12 % (worst (1,1), ρ = 0.95, σ_x²/σ_θ² = 1; all n ≥ 2
   cases ≤ +0.47 %); smoothed gap vs the Wiener bound ≤ +2.10 %.  m = 4 for (1,1) ρ = 0.95:
   ≤ +0.67 %.  Outside the target grid, (1,1) ρ = 0.99: m = 4 loses +3.1…+5.7 % (m = 1: +6…+20 %).
   With m = max(n_x, 2) for every model (48×48, same grid, ``benches/bench_row_filters.py``):
   causal loss ≤ +2.05 % (the same (1,1) worst case), all n ≥ 2 cases ≤ +0.46 %; smoothed
   gap ≤ +2.03 %.  With ``default_ar_order`` (m = 8 for n_y = 1; 2026-11-27, after the
   drift scale): loss ≤ +0.34 %, gap ≤ +0.65 %, both (2,2), ρ = 0.95, σ_x²/σ_θ² = 10.
   The current tables: the benchmark page *Row filters* (``benches/bench_row_filters.py``).

4. ``linear_estimator_mse`` gives the exact per-pixel MSE of ANY linear row estimator by
   applying it to the columns of a square root of Cov(x) and of the noise covariance:
   MSE = Σ_c (E x_c − x_c)² + s Σ_q (E e_q)²  (no Monte Carlo).  ``scalar_error_map`` wraps it.
   ``brute_force_kalman`` is the batch GLS (whole image as one Gaussian vector).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sparse
from scipy.linalg import cho_solve_banded, cholesky_banded, eigh, solve_triangular, toeplitz

from ..field.ar_field import axis_ar_coefficients, axis_correlation, beta_tilde_sq

# ----------------------------------------------------------------------------------------------
# model pieces


def axis_covariance(rho: float, n: int, size: int) -> np.ndarray:
    """Toeplitz(R(|i-j|)) of one axis, normalised (§1.1 [P 2.9])."""
    return toeplitz(axis_correlation(rho, n, np.arange(size)))


def companion(rho: float, n: int) -> np.ndarray:
    """A_y: first row α_1..α_n [P 2.8], identity below (§2.2 [P 3.18])."""
    a = np.zeros((n, n))
    a[0] = axis_ar_coefficients(rho, n)
    a[1:, :-1] = np.eye(n - 1)
    return a


def row_modes(rho_x: float, n_x: int, sigma: float, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Eigen-decomposition T_x = σ² R_x = U diag(λ) Uᵀ (used by §2.2 in modal form)."""
    lam, u = eigh(sigma**2 * axis_covariance(rho_x, n_x, width))
    return np.clip(lam, 0.0, None), u


def toeplitz_modes(rho_x: float, n_x: int, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """Fourier modes of the infinite row (twin of ``RowModes::toeplitz``): (σ² λ_g, w_g) on
    the trapezoid nodes ω_g = πg/G, G = clip(⌈24/(1 − ρ_x)⌉, 256, 65536), λ_g ∝
    (1 − 2ρ_x cos ω_g + ρ_x²)^(−n_x) normalised to trapezoid mean 1 [P 2.11]."""
    intervals = int(np.clip(np.ceil(24.0 / (1.0 - rho_x)), 256, 1 << 16))
    weights = np.full(intervals + 1, 1.0 / intervals)
    weights[[0, -1]] *= 0.5
    omega = np.pi * np.arange(intervals + 1) / intervals
    raw = (1.0 - 2.0 * rho_x * np.cos(omega) + rho_x**2) ** (-float(n_x))
    return sigma**2 * raw / (raw @ weights), weights


def ends_modes(rho_x: float, n_x: int, sigma: float, span: int):
    """Twin of ``RowModes::ends``: the eigenbasis of a row of `span` points, then the Fourier
    modes.  Returns (λ: the span row's, then the nodes'; (U_span, trapezoid weights))."""
    lam, u = row_modes(rho_x, n_x, sigma, span)
    lam_g, weights = toeplitz_modes(rho_x, n_x, sigma)
    return np.concatenate([lam, lam_g]), (u, weights)


def ends_band(modes: tuple, modal_cov: np.ndarray, m: int, width: int) -> list:
    """Twin of ``RowModes::band`` for the "ends" modes: rows ℓ < W'/2 from the left half of the
    W'-row's exact band, rows ℓ ≥ W − W'/2 from its right half, the Toeplitz band between."""
    u, weights = modes
    span = u.shape[0]
    exact = prediction_band(u, modal_cov[:span], m)
    band = toeplitz_band(weights, modal_cov[span:], m, width)
    half = span // 2
    for d, lag in enumerate(band):
        lag[:half] = exact[d][:half]
        lag[width - half : width - d] = exact[d][span - half : span - d]
    return band


def toeplitz_band(weights: np.ndarray, modal_cov: np.ndarray, m: int, width: int) -> list:
    """``prediction_band`` for the Toeplitz modes: block d = (1/π)∫ cos(dω) P(ω) dω by the
    trapezoid rule, the same for every ℓ (shape (W−d, n, n))."""
    omega = np.pi * np.arange(weights.size) / (weights.size - 1)
    out = []
    for d in range(min(m, width - 1) + 1):
        block = np.einsum("g,gab->ab", weights * np.cos(d * omega), modal_cov)
        out.append(np.broadcast_to(block, (width - d, *block.shape)).copy())
    return out


def row_schedule(n: int, height: int) -> list[tuple[bool, int]]:
    """For each row t = 1..height: (predict?, observed state index).  Rows 1..n observe the
    static stack (x̄_n..x̄_1) at index n−t; later rows predict with S and observe index 0."""
    return [(t > n, n - t if t <= n else 0) for t in range(1, height + 1)]


# ----------------------------------------------------------------------------------------------
# 1. Wiener bound


def _wiener_factors(rho, order, sigma, noise_var, shape):
    ly, uy = eigh(axis_covariance(rho[0], order[0], shape[0]))
    lx, ux = eigh(axis_covariance(rho[1], order[1], shape[1]))
    lam = sigma**2 * np.outer(np.clip(ly, 0, None), np.clip(lx, 0, None))
    return uy, lam * noise_var / (lam + noise_var), ux


def wiener_error_map(rho, order, sigma, noise_var, shape) -> np.ndarray:
    """Per-pixel error variance of the best linear non-causal estimator on the finite grid
    (§2.4 bound): diag of the posterior covariance, via Cov(x) = σ² R_y ⊗ R_x."""
    uy, post, ux = _wiener_factors(rho, order, sigma, noise_var, shape)
    return (uy**2) @ post @ (ux**2).T


def wiener_bound(rho, order, sigma, noise_var, shape) -> float:
    """Mean error variance of the best linear non-causal estimator (§2.4): mean(f_ab)."""
    return float(np.mean(_wiener_factors(rho, order, sigma, noise_var, shape)[1]))


# ----------------------------------------------------------------------------------------------
# 2. optimal vector row filter (modal form of §2.1–2.2)


def modal_riccati(rho, order, sigma, noise_var, width, height, modes="exact", span=None):
    """Riccati recursion of the optimal row filter (§2.2 [P 3.29, 3.30]), one n×n filter per
    eigen-mode λ_j of T_x.  Returns (λ, U_x, steps); steps[t] = dict(pe, pf, gain) with arrays of
    shape (W, n, n), (W, n, n), (W, n): prediction / filtered covariances and Kalman gains.
    modes="toeplitz": the Fourier modes of ``toeplitz_modes`` (U_x is then their weights);
    modes="ends": those of ``ends_modes`` on a `span`-point row (U_x: (U_span, weights))."""
    n = order[0]
    if modes == "toeplitz":
        lam, u = toeplitz_modes(rho[1], order[1], sigma)
    elif modes == "ends":
        lam, u = ends_modes(rho[1], order[1], sigma, span)
    else:
        lam, u = row_modes(rho[1], order[1], sigma, width)
    a = companion(rho[0], n)
    q = np.zeros((n, n))
    q[0, 0] = beta_tilde_sq(rho[0], n)
    p = lam[:, None, None] * axis_covariance(rho[0], n, n)[None]
    steps = []
    for predict, i in row_schedule(n, height):
        if predict:
            p = a @ p @ a.T + lam[:, None, None] * q
            p = 0.5 * (p + p.transpose(0, 2, 1))
        pe = p
        s = pe[:, i, i] + noise_var
        gain = pe[:, :, i] / s[:, None]
        # P_e − c cᵀ/s, c = P_e e_i: exactly symmetric (P_e rounds to indefinite otherwise)
        p = pe - pe[:, :, i, None] * pe[:, None, :, i] / s[:, None, None]
        steps.append({"pe": pe, "pf": p, "gain": gain})
    return lam, u, steps


def whitened_prediction_errors(lam, rho_y, n, noise_var, height) -> list[np.ndarray]:
    """P_e,t' = T P_e,t Tᵀ per mode (W, n, n) for rows t = 1..height (twin of
    ``RowDynamics::whitened(..).prediction_errors``): the Riccati of ``modal_riccati`` run in
    the whitened row basis of ``row_basis`` (prior I, transition T A L, innovation
    β̃² (T e₀)(T e₀)ᵀ, row t observing row ``row_schedule``'s index of L), where every quantity
    is O(1) and P_e' stays positive semi-definite; whitening P_e afterwards turned its
    rounding into an indefinite band for n = 4 at ρ = 0.999."""
    tmat, lower = row_basis(rho_y, n)
    a = tmat @ companion(rho_y, n) @ lower
    q = beta_tilde_sq(rho_y, n) * np.outer(tmat[:, 0], tmat[:, 0])
    p = np.broadcast_to(np.eye(n), (len(lam), n, n)).copy()
    with np.errstate(divide="ignore"):  # a mode of variance 0 is not corrected
        ratio = noise_var / lam
    out = []
    for predict, i in row_schedule(n, height):
        if predict:
            p = a @ p @ a.T + q
            p = 0.5 * (p + p.transpose(0, 2, 1))
        out.append(lam[:, None, None] * p)
        c = p @ lower[i]
        p = p - c[:, :, None] * c[:, None, :] / (c @ lower[i] + ratio)[:, None, None]
    return out


def steady_prediction(rho, order, sigma, noise_var, width, tol=1e-13, max_rows=100000):
    """Steady-state prediction covariance P_e,∞ of the optimal row filter, per mode (W, n, n):
    the modal Riccati of ``modal_riccati`` iterated until the relative change is < tol."""
    n = order[0]
    lam, _ = row_modes(rho[1], order[1], sigma, width)
    a = companion(rho[0], n)
    q = np.zeros((n, n))
    q[0, 0] = beta_tilde_sq(rho[0], n)
    pe = lam[:, None, None] * axis_covariance(rho[0], n, n)[None]
    for _ in range(max_rows):
        pf = pe - pe[:, :, :1] * pe[:, :1, :] / (pe[:, :1, :1] + noise_var)
        new = a @ pf @ a.T + lam[:, None, None] * q
        if np.max(np.abs(new - pe)) <= tol * np.max(np.abs(new)):
            return new
        pe = new
    return pe


def _as_batch(z: np.ndarray) -> tuple[np.ndarray, bool]:
    z = np.asarray(z, dtype=float)
    return (z[..., None], True) if z.ndim == 2 else (z, False)


def vector_row_filter(z, rho, order, sigma, noise_var, smooth=False):
    """Optimal vector row filter, §2.1–2.2 with the exact start of §2.2 ([P §4.3]), and, with
    smooth=True, the row-wise RTS smoother.  z: (H, W) or a batch (H, W, B).
    Returns (estimate, error_variance_map); the map is the exact per-pixel MSE (diag P)."""
    zb, single = _as_batch(z)
    height, width, _ = zb.shape
    n = order[0]
    lam, u, steps = modal_riccati(rho, order, sigma, noise_var, width, height)
    a = companion(rho[0], n)
    zt = np.einsum("hwb,wj->hjb", zb, u)  # rows in the eigenbasis, (H, W, B)
    mean = np.zeros((width, n, zb.shape[2]))
    filt, pred = [], []
    for (predict, i), st, zk in zip(row_schedule(n, height), steps, zt):
        if predict:
            mean = np.einsum("ab,jbk->jak", a, mean)
        pred.append(mean)
        mean = mean + st["gain"][:, :, None] * (zk - mean[:, i, :])[:, None, :]
        filt.append(mean)
    t0 = min(n, height) - 1  # last static step (0-based)
    means, covs = list(filt), [st["pf"] for st in steps]
    if smooth:
        for t in range(height - 2, t0 - 1, -1):
            pf, pe = steps[t]["pf"], steps[t + 1]["pe"]
            j = smoother_gains(pf, pe, a)
            means[t] = filt[t] + np.einsum("jab,jbk->jak", j, means[t + 1] - pred[t + 1])
            covs[t] = pf + j @ (covs[t + 1] - pe) @ j.transpose(0, 2, 1)
        for t in range(t0):
            means[t], covs[t] = means[t0], covs[t0]
    est, modal = np.empty_like(zb), np.empty((height, width))
    for t in range(height):
        i = n - 1 - t if t < n else 0
        est[t] = u @ means[t][:, i, :]
        modal[t] = covs[t][:, i, i]
    if smooth:
        with np.errstate(divide="ignore"):
            ratio = noise_var / lam
        for j in np.flatnonzero(ratio <= INFORMATION_RATIO):
            modal[:, j] = lam[j] * information_column(rho[0], n, ratio[j], height)
    return (est[..., 0] if single else est), modal @ (u**2).T


# Modes with σ_θ²/λ_j at most this take the smoothed map from the information form (twin of
# ``vector_row_filter::INFORMATION_RATIO``).
INFORMATION_RATIO = 1e-4


def column_precision(rho_y: float, n: int, height: int) -> np.ndarray:
    """R_y⁻¹ of `height` rows (dense here; banded, bandwidth n): the exact stationary start's
    density p(x_0..x_{n−1}) p(x_n | …) ⋯ as T_kᵀT_k on the first k = min(n, H) rows (T of
    ``row_basis``) plus g gᵀ/β̃² per later row, g = (−α_n, …, −α_1, 1) (§1.3, [P 2.8])."""
    tmat, _ = row_basis(rho_y, n)
    k = min(n, height)
    q = np.zeros((height, height))
    q[:k, :k] = tmat[:k, :k].T @ tmat[:k, :k]
    g = np.concatenate([-companion(rho_y, n)[0][::-1], [1.0]])
    innovation_term = np.outer(g, g) / beta_tilde_sq(rho_y, n)
    for t in range(n, height):
        q[t - n : t + 1, t - n : t + 1] += innovation_term
    return q


def information_column(rho_y: float, n: int, ratio: float, height: int) -> np.ndarray:
    """Smoothed error variance, in units of the mode's variance, of one mode's column process
    (covariance R_y, white noise `ratio`): diag (R_y⁻¹ + I/ratio)⁻¹ = ratio diag (I + ratio
    R_y⁻¹)⁻¹, nothing cancelling at ratio ≪ 1 (the RTS covariances lose ε/ratio there)."""
    m = np.eye(height) + ratio * column_precision(rho_y, n, height)
    return ratio * np.diag(np.linalg.inv(m))


def smoother_gains(pf: np.ndarray, pe: np.ndarray, a: np.ndarray) -> np.ndarray:
    """J = P_f Aᵀ P_e⁻¹ per mode (symmetric P), by Cholesky; J = 0 for a mode whose P_e is not
    numerically positive definite (that mode keeps its filtered value), as in Rust."""
    rhs = a @ pf
    j = np.zeros_like(pf)
    for k in range(pe.shape[0]):
        try:
            low = np.linalg.cholesky(pe[k])
        except np.linalg.LinAlgError:
            continue
        j[k] = np.linalg.solve(low.T, np.linalg.solve(low, rhs[k])).T
    return j


def vector_error_map(rho, order, sigma, noise_var, shape, smooth=False) -> np.ndarray:
    """(H, W) map of the per-pixel error variance of ``vector_row_filter`` (data-independent)."""
    return vector_row_filter(np.zeros(shape), rho, order, sigma, noise_var, smooth)[1]


def brute_force_kalman(z, rho, order, sigma, noise_var, smooth=False):
    """Batch GLS on the whole image (small images only, O((HW)³)): causal row t uses z rows
    1..t; smooth=True uses all of z.  Returns (estimate, error_variance_map)."""
    z = np.asarray(z, dtype=float)
    height, width = z.shape
    cov = sigma**2 * np.kron(
        axis_covariance(rho[0], order[0], height), axis_covariance(rho[1], order[1], width)
    )
    est, var = np.empty_like(z), np.empty_like(z)
    for t in range(1, height + 1):
        if smooth and t < height:
            continue
        obs = slice(0, t * width)
        czz = cov[obs, obs] + noise_var * np.eye(t * width)
        gain = np.linalg.solve(czz, cov[obs, :]).T  # (HW, t·W)
        post = gain @ z[:t].ravel()
        pvar = np.diag(cov) - np.einsum("ij,ij->i", gain, cov[:, obs])
        if smooth:
            est, var = post.reshape(z.shape), pvar.reshape(z.shape)
        else:
            rows = slice((t - 1) * width, t * width)
            est[t - 1], var[t - 1] = post[rows], pvar[rows]
    return est, var


# ----------------------------------------------------------------------------------------------
# 3. quasi-optimal banded-precision row filter


def prediction_band(u: np.ndarray, modal_cov: np.ndarray, m: int) -> list[np.ndarray]:
    """Band blocks Cov(v_ℓ, v_{ℓ+d}) = Σ_j U[ℓ,j] U[ℓ+d,j] P_j, d = 0..m, of a row-state
    covariance given per mode (P_j: (W, n, n)).  Block d has shape (W−d, n, n)."""
    width = u.shape[0]
    blocks = range(min(m, width - 1) + 1)  # no column pairs farther apart than the row
    return [np.einsum("lj,lj,jab->lab", u[: width - d], u[d:], modal_cov) for d in blocks]


def _block_cov(band, i, j):
    """Cov(v_i, v_j) from band blocks."""
    return band[j - i][i] if i <= j else band[i - j][j].T


INTERIOR_TOLERANCE = 1e-5
"""Twin of ``scalar_row_filter.rs``'s: the relative distance within which a column's term of
Λ is replaced by the middle column's (``markov_precision``)."""


def column_model(band: list[np.ndarray], ell: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    """(Γ_ℓ, D_ℓ) of the block AR model of column ℓ over its past ℓ−1, …, ℓ−min(ℓ, m)
    ([P 3.11, 3.12, 3.34–3.36]): Γ_ℓ = C_{ℓ,past} C_{past,past}⁻¹,
    D_ℓ = C_{ℓℓ} − Γ_ℓ C_{past,ℓ} (symmetrised)."""
    n = band[0].shape[1]
    past = list(range(ell - 1, max(ell - m, 0) - 1, -1))
    dcov = band[0][ell]
    gam = np.zeros((n, 0))
    if past:
        cpp = np.block([[_block_cov(band, i, j) for j in past] for i in past])
        clp = np.hstack([_block_cov(band, ell, j) for j in past])
        gam = np.linalg.solve(cpp, clp.T).T
        dcov = dcov - gam @ clp.T
    return gam, 0.5 * (dcov + dcov.T)


def root_contribution(band: list[np.ndarray], ell: int, m: int, jitter: float) -> np.ndarray:
    """Column ℓ's term of Λ in square-root form (twin of ``ScalarRowFilter::
    root_contribution``): C = L Lᵀ, C the joint covariance of the past ℓ−k, …, ℓ−1 and
    column ℓ plus jitter · max_i C_ii I; the last n rows of L⁻¹ are G = L_ℓℓ⁻¹ [−Γ_ℓ, I], and
    the term is GᵀG (positive semi-definite whatever the rounding), returned in the order
    (ℓ, ℓ−1, …, ℓ−k) of ``contribution``."""
    n = band[0].shape[1]
    columns = list(range(max(ell - m, 0), ell + 1))
    joint = np.block([[_block_cov(band, i, j) for j in columns] for i in columns])
    joint = 0.5 * (joint + joint.T)
    joint += jitter * np.max(np.diag(joint)) * np.eye(len(joint))
    inverse = solve_triangular(np.linalg.cholesky(joint), np.eye(len(joint)), lower=True)
    rows = inverse[-n:]
    g = np.hstack([rows[:, b * n : (b + 1) * n] for b in reversed(range(len(columns)))])
    return g.T @ g


def markov_precision(
    band: list[np.ndarray],
    m: int,
    toeplitz_rows: range = range(0),
    jitter: float | None = None,
    periodic: bool = True,
) -> sparse.csr_matrix:
    """Precision Λ = Lᵀ D⁻¹ L = Σ_ℓ B_ℓᵀ D_ℓ⁻¹ B_ℓ of the block AR(m) model along the row
    fitted to the band (``column_model``); a column with a full past whose term lies within
    INTERIOR_TOLERANCE of the middle column's takes the middle one's (twin of
    ``ScalarRowFilter::precision``: an exactly periodic interior).  `toeplitz_rows`: the rows
    holding the Toeplitz blocks (modes "ends"); a column with a full past that reaches one
    takes the middle column's term without a fit of its own (a fit straddling the splice
    mixes two sources and can be indefinite).  `jitter`: None for the direct fit, else the
    square-root one (``root_contribution``).  `periodic` False: every column its own fit (a
    band of no row structure, ``propagated_system``).  Interleaved ordering (ℓ, i) ↦ ℓ·n + i."""
    width, n = band[0].shape[0], band[0].shape[1]
    middle = width // 2

    def term(ell: int) -> np.ndarray:
        if jitter is None:
            return contribution(*column_model(band, ell, m), n)
        return root_contribution(band, ell, m, jitter)

    central = term(middle) if middle >= m and periodic else None
    steady = range(max(m, toeplitz_rows.start), toeplitz_rows.stop + m) if toeplitz_rows else ()
    rows, cols, vals = [], [], []
    for ell in range(width):
        past = list(range(ell - 1, max(ell - m, 0) - 1, -1))
        if central is not None and ell in steady:
            q = central
        else:
            q = term(ell)
        if central is not None and len(past) == m and is_settled(q, central):
            q = central
        index = np.concatenate([np.arange(c * n, (c + 1) * n) for c in [ell] + past])
        r, c = np.meshgrid(index, index, indexing="ij")
        rows.append(r.ravel())
        cols.append(c.ravel())
        vals.append(q.ravel())
    size = width * n
    return sparse.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), (size, size)
    )


def contribution(gam: np.ndarray, dcov: np.ndarray, n: int) -> np.ndarray:
    """Column ℓ's term Bᵀ D⁻¹ B of Λ, B = [I, −Γ_ℓ] over the columns ℓ, ℓ−1, …, ℓ−k."""
    b = np.hstack([np.eye(n), -gam])
    return b.T @ np.linalg.inv(dcov) @ b


def is_settled(q: np.ndarray, central: np.ndarray) -> bool:
    """Whether q lies within INTERIOR_TOLERANCE of the middle column's contribution."""
    return bool(np.max(np.abs(q - central)) <= INTERIOR_TOLERANCE * np.max(np.abs(central)))


def banded_cholesky(mat: sparse.spmatrix, bandwidth: int) -> np.ndarray:
    """Upper banded Cholesky factor (LAPACK storage) of a symmetric banded sparse matrix."""
    size = mat.shape[0]
    ab = np.zeros((bandwidth + 1, size))
    for k in range(bandwidth + 1):
        ab[bandwidth - k, k:] = mat.diagonal(k)
    return cholesky_banded(ab)


def row_basis(rho_y: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(T, L): L = chol(R_y[:n,:n]) (lower, L₀₀ = 1), T = L⁻¹.  The quasi-optimal filter works
    on the whitened state v' = T v of every column: mathematically the same model (the block
    AR fit is equivariant under a constant per-column transform), but the start prior becomes
    I ⊗ T_x instead of R_y[:n,:n] ⊗ T_x, whose condition number reaches 1e14 for n = 4.
    x_k = (L v')₀ = v'₀, so the current row is still read off component 0."""
    lower = np.linalg.cholesky(axis_covariance(rho_y, n, n))
    return np.linalg.inv(lower), lower


def observation_block(lower: np.ndarray, index: int, width: int, noise_var: float):
    """HᵀH/s = I_W ⊗ h hᵀ/s with h = row `index` of L (observation of x at state index)."""
    h = lower[index]
    return sparse.kron(sparse.identity(width), np.outer(h, h) / noise_var, format="csr")


def default_ar_order(n_y, n_x):
    """Twin of the Rust ``default_ar_order``: m = 8 for n_y = 1, model_ar_order(n_x) otherwise."""
    return 8 if n_y == 1 else model_ar_order(n_x)


def model_ar_order(n_x):
    """Twin of the Rust ``model_ar_order``: m = n_x, at least 2, at most 8."""
    return min(max(n_x, 2), 8)


def scalar_filter_plan(
    rho,
    order,
    sigma,
    noise_var,
    width,
    height,
    ar_order=None,
    tol=1e-3,
    transient=True,
    modes="exact",
    span=None,
):
    """Precomputed per-row quantities of the quasi-optimal filter (module doc, part 3), in the
    whitened row basis of ``row_basis``: list over rows t of dict(prec=Λ_t (sparse),
    chol=banded Cholesky of A_t, index=observed state index, predict=bool).
    transient=True: Λ_t is refitted to the band of the optimal P_e,t whenever that band has
    drifted from the fitted one by > tol of ``drift_scale`` (the band of P_e,t − Q), until it
    settles (``settled``, on the same scale; a refit that fails,
    beyond float64, keeps the last model).  transient=False: one model, fitted to the
    steady-state P_e,∞, serves every row after the (exact) start.  ar_order None →
    ``default_ar_order``.  modes="toeplitz": the band from the Fourier modes of the infinite row
    (``toeplitz_band``); modes="ends": spliced with the exact band of a `span`-point row at
    both ends (``ends_band``; the Rust filter's ``ends_span``)."""
    n, m = order[0], (default_ar_order(*order) if ar_order is None else ar_order)
    bw = n * (m + 1) - 1
    if modes == "ends" and span is None:
        raise ValueError("modes=\"ends\" needs the span W' (the Rust filter's ends_span)")
    tmat, lower = row_basis(rho[0], n)
    a_white = tmat @ companion(rho[0], n) @ lower
    lam, u, steps = modal_riccati(rho, order, sigma, noise_var, width, 0, modes, span)
    steps = [{"pe": pe} for pe in whitened_prediction_errors(lam, rho[0], n, noise_var, height)]
    toeplitz_rows = {
        "exact": range(0),
        "toeplitz": range(width),
        "ends": range((span or 0) // 2, width - (span or 0) // 2),
    }[modes]

    def prediction_band_of(pe):
        if modes == "toeplitz":
            return toeplitz_band(u, pe, m, width)
        if modes == "ends":
            return ends_band(u, pe, m, width)
        return prediction_band(u, pe, m)

    def precision_of(band):
        return lambda jitter: markov_precision(band, m, toeplitz_rows, jitter)

    if not transient:
        pe_inf = tmat @ steady_prediction(rho, order, sigma, noise_var, width) @ tmat.T
        steps = [st if t < n else {"pe": pe_inf} for t, st in enumerate(steps)]
    innovation = prediction_band_of(lam[:, None, None] * (np.eye(n) - a_white @ a_white.T)[None])
    plan, prec, chol, start = [], None, None, []
    fitted, prev_band, models = None, None, 0
    prev_change = earlier_change = None
    frozen = False  # once the bands have settled (``settled``), the model stays fixed
    for t, ((predict, i), st) in enumerate(zip(row_schedule(n, height), steps)):
        pe = 0.5 * (st["pe"] + st["pe"].transpose(0, 2, 1))
        if not predict:  # static start: exact stationary prior, accumulated observations
            if t == 0:
                prior = precision_of(prediction_band_of(pe))  # exact if m ≥ n_x
                observed = [observation_block(lower, n - 1, width, noise_var)]
                for k in range(n - 2, -1, -1):
                    observed.append(observed[-1] + observation_block(lower, k, width, noise_var))
                prec, start = sound_systems(prior, observed, bw)
            plan.append(
                {"prec": prec, "chol": start[t], "index": i, "predict": False, "bandwidth": bw}
            )
            continue
        if frozen:
            plan.append({"prec": prec, "chol": chol, "index": 0, "predict": True, "bandwidth": bw})
            continue
        band = prediction_band_of(pe)
        scale = drift_scale(band, innovation)
        if fitted is None or band_change(band, fitted) > tol * scale:
            try:
                observed = [observation_block(lower, 0, width, noise_var)]
                prec, (chol,) = sound_systems(precision_of(band), observed, bw)
                fitted, models = band, models + 1
            except np.linalg.LinAlgError:
                if fitted is None:
                    raise
                frozen = True  # a later row's fit beyond float64: keep the last sound model
        frozen = frozen or models == MAX_ROW_MODELS
        if prev_band is not None:
            change = band_change(band, prev_band) / scale
            frozen = frozen or settled(change, prev_change, earlier_change, tol)
            earlier_change, prev_change = prev_change, change
        prev_band = band
        plan.append({"prec": prec, "chol": chol, "index": 0, "predict": True, "bandwidth": bw})
    if plan:  # what ``weighted_systems`` needs to refit the row models
        plan[0].update(
            transition=a_white,
            innovation=innovation,
            ar_order=m,
            noise_var=noise_var,
        )
    return plan


DRIFT_FLOOR = 1e-9
"""Twin of ``scalar_row_filter.rs``'s: the drift scale is at least this fraction of the
band's largest entry (P_e's rounding stays far below the refit tolerance)."""


def drift_scale(band: list[np.ndarray], innovation: list[np.ndarray]) -> float:
    """Scale the row-to-row changes of the band of P_e,t are measured against (twin of
    ``scalar_row_filter.rs``'s ``drift_scale``): the largest entry of the band of
    P_e,t − Q = S P_f,t−1 Sᵀ, the part of the prediction error that changes from row to row
    (Q, the innovation, is the same on every row), floored at DRIFT_FLOOR times the band's
    largest entry. Against the band's largest entry alone, at high SNR (P_e ≈ Q there) the
    changes that matter looked 10²–10⁴ times smaller than they are and the models froze
    early: (1,2), ρ = 0.99, σ_x²/σ_θ² = 1e4 lost 16 % instead of 12 % (32²)."""
    largest = float(np.max(np.abs(band[0])))
    return max(float(np.max(np.abs(band[0] - innovation[0]))), DRIFT_FLOOR * largest)


JITTERS = (0.0, 1e-15, 1e-14, 1e-13, 1e-12, 1e-11, 1e-10, 1e-9)
"""Twin of ``scalar_row_filter.rs``'s: jitters of the square-root fit (``root_contribution``),
smallest first, for row models whose direct fit or systems fail in float64 (near ρ = 1 the
innovation variance of an AR(n_x) fit along the row falls to the band's rounding)."""


def sound_systems(
    precision_of, observed: list, bandwidth: int
) -> tuple[sparse.spmatrix, list[np.ndarray]]:
    """(Λ, [banded Cholesky of Λ + o for o in observed]) with Λ = precision_of(None), the
    direct fit; if it or a system fails, Λ = precision_of(ε), the square-root fit, with the
    smallest ε of JITTERS for which Λ itself and every system factor (twin of
    ``ScalarRowFilter::sound_systems``); without one, the direct fit's failure."""
    try:
        prec = precision_of(None)
        return prec, [banded_cholesky(prec + o, bandwidth) for o in observed]
    except np.linalg.LinAlgError as error:
        failure = error
    for epsilon in JITTERS:
        try:
            prec = precision_of(epsilon)
            banded_cholesky(prec, bandwidth)
            return prec, [banded_cholesky(prec + o, bandwidth) for o in observed]
        except np.linalg.LinAlgError:
            continue
    raise failure


MAX_ROW_MODELS = 64
"""Twin of ``scalar_row_filter.rs``'s: the most row models (Λ_t and its factor) a plan fits
after the start rows; then the last one serves the remaining rows (memory). The kernel
lowers it (to no less than 16) for rows so wide that 64 models would take more than 1 GiB
(W ≳ 5200 for (4,4)); the twin, never run that wide, keeps 64."""


def band_change(band: list[np.ndarray], other: list[np.ndarray]) -> float:
    """Largest entry-wise difference between two bands of blocks."""
    return max(float(np.max(np.abs(b - c))) for b, c in zip(band, other))


RATIO_RISE = 0.05
"""Twin of ``scalar_row_filter.rs``'s: the most the ratio of successive changes may rise from
one row to the next for their geometric tail to be trusted (``settled``)."""


def settled(change: float, previous: float | None, earlier: float | None, tol: float) -> bool:
    """Whether a sequence whose latest relative change is `change` (the two before:
    `previous`, `earlier`) is within `tol` of its limit: change / (1 − q) ≤ tol with q =
    change / previous, the geometric tail the last two changes imply, provided q is not rising
    by more than RATIO_RISE against previous / earlier (a contraction that slows down is a
    slower mode taking over) (twin of ``scalar_row_filter.rs``'s ``settled``). At q ≥ 0.999
    (not contracting yet, or changes at the rounding floor) the bound is change ≤ 1e-3 tol.
    One row's change ≤ tol alone froze slowly converging Riccatis (ρ = 0.999) far from their
    limit; the tail without the rising check froze (2,2) at ρ_y = 0.9999 at its fifth row."""
    if change == 0.0:
        return True
    if previous is None:
        return False

    def ratio(a: float, b: float) -> float:
        return min(a / b, 1.0) if b > 0 else 1.0

    q = ratio(change, previous)
    if q < 0.999 and (earlier is None or q > ratio(previous, earlier) + RATIO_RISE):
        return False
    return change <= tol * max(1.0 - q, 1e-3)


def _apply_block(a: np.ndarray, state: np.ndarray, n: int) -> np.ndarray:
    """(I_W ⊗ a) v in interleaved ordering: v_ℓ ↦ a v_ℓ for every column ℓ.  state: (W·n, B)."""
    b = state.shape[1]
    return np.einsum("ab,lbk->lak", a, state.reshape(-1, n, b)).reshape(-1, b)


def scalar_row_filter(
    z,
    rho,
    order,
    sigma,
    noise_var,
    ar_order=None,
    smooth=False,
    plan=None,
    weights=None,
    row_models="propagated",
):
    """Quasi-optimal row filter (§2.3 generalised, module doc part 3), O(W n² m) per row.
    z: (H, W) or batch (H, W, B).  Returns the estimate (causal, or RTS-smoothed).
    weights: (H, W) per-pixel 1/σ_θ² (0 = missing pixel), see ``weighted_systems``."""
    causal, smoothed = scalar_row_passes(
        z, rho, order, sigma, noise_var, ar_order, smooth, plan, weights, row_models
    )
    return smoothed if smooth else causal


def weighted_systems(plan, lower, weights, row_models="propagated"):
    """Banded Cholesky factors of A_t = Λ_t + Σ_ℓ w_tℓ h hᵀ (block ℓ) for per-pixel weights
    w = 1/σ_θ² (0 = missing): the start rows keep the plan's prior and accumulate their
    observations; the later rows keep the plan's Λ_t down to the first row whose weights
    depart from the nominal 1/σ_θ² (beyond 1e-12 relative), and after it every row's Λ_t is
    refitted to S A_{t−1}⁻¹ Sᵀ + Q (``propagated_system``; twin of the Rust
    ``propagated_models``); with row_models "nominal" every row keeps the plan's; with
    "implied" every predicted row's is propagated, whatever the weights."""
    start, out = None, []
    nominal = 1.0 / plan[0]["noise_var"]
    departed = row_models == "implied"
    for step, row_weights in zip(plan, weights):
        h = lower[step["index"]]
        obs = sparse.kron(sparse.diags(row_weights), np.outer(h, h), format="csr")
        if step["predict"] and departed and row_models != "nominal":
            chol = propagated_system(plan[0], step, out[-1], obs)
        elif step["predict"]:
            chol = banded_cholesky(step["prec"] + obs, step["bandwidth"])
        else:
            start = obs if start is None else start + obs
            chol = banded_cholesky(step["prec"] + start, step["bandwidth"])
        departed = departed or bool(np.any(np.abs(row_weights - nominal) > 1e-12 * nominal))
        out.append(chol)
    return out


def propagated_system(head, step, previous, obs):
    """The factor of A_t = Λ_t + obs with Λ_t fitted (``markov_precision``, every column its
    own fit) to the band of S A_{t−1}⁻¹ Sᵀ + Q, Q = σ² R_x ⊗ (I − S Sᵀ) (`head`: the plan's
    first step, holding S, Q's band and m); the direct fit, else the square-root one with the
    smallest working jitter of JITTERS, else the plan's Λ_t (twin of
    ``ScalarRowFilter::propagated_model``; A_{t−1}⁻¹ dense here)."""
    a, m, bw = head["transition"], head["ar_order"], step["bandwidth"]
    n = a.shape[0]
    size = previous.shape[1]
    width = size // n
    z = cho_solve_banded((previous, False), np.eye(size)).reshape(width, n, width, n)
    band = [
        np.einsum("ab,lbc,dc->lad", a, z[np.arange(width - d), :, np.arange(d, width), :], a) + q
        for d, q in enumerate(head["innovation"])
    ]
    for jitter in (None, *JITTERS):
        try:
            prec = markov_precision(band, m, jitter=jitter, periodic=False)
            return banded_cholesky(prec + obs, bw)
        except np.linalg.LinAlgError:
            continue
    return banded_cholesky(step["prec"] + obs, bw)


def scalar_row_passes(
    z,
    rho,
    order,
    sigma,
    noise_var,
    ar_order=None,
    smooth=True,
    plan=None,
    weights=None,
    row_models="propagated",
):
    """Both passes of ``scalar_row_filter``: (causal estimate, smoothed estimate or None)."""
    zb, single = _as_batch(z)
    height, width, nb = zb.shape
    n = order[0]
    if plan is None:
        plan = scalar_filter_plan(rho, order, sigma, noise_var, width, height, ar_order)
    tmat, lower = row_basis(rho[0], n)
    if weights is None and row_models == "implied":
        weights = np.full((height, width), 1.0 / noise_var)
    if weights is None:
        chols = [step["chol"] for step in plan]
        weights = np.full((height, width), 1.0 / noise_var)
    else:
        weights = np.asarray(weights, dtype=np.float64)
        chols = weighted_systems(plan, lower, weights, row_models)
    a = tmat @ companion(rho[0], n) @ lower  # transition in the whitened basis
    state = np.zeros((width * n, nb))
    info = np.zeros((width * n, nb))  # Σ Hᵀ w z during the static start
    filt = []
    for step, chol, zk, wk in zip(plan, chols, zb, weights):
        h = lower[step["index"]]
        if step["predict"]:  # prediction, innovation, banded gain solve
            state = _apply_block(a, state, n)
            innov = zk - state.reshape(width, n, nb)[:, 0, :]  # h = e₀ after the start
            innov = np.where(wk[:, None] > 0, innov * wk[:, None], 0.0)
            gain_in = (h[None, :, None] * innov[:, None, :]).reshape(-1, nb)
            state = state + cho_solve_banded((chol, False), gain_in)
        else:  # static start: information form, exact
            seen = np.where(wk[:, None] > 0, zk * wk[:, None], 0.0)
            info = info + (h[None, :, None] * seen[:, None, :]).reshape(-1, nb)
            state = cho_solve_banded((chol, False), info)
        filt.append(state)
    t0 = min(n, height) - 1
    means = None
    if smooth:  # RTS over rows: ŷˢ_t = ŷ_t + A_t⁻¹ Sᵀ Λ_{t+1} (ŷˢ_{t+1} − ŷ_e,t+1)
        means = list(filt)
        carried = np.zeros_like(state)  # d_{t+1} = A_{t+1} (ŷˢ_{t+1} − ŷ_{t+1})
        for t in range(height - 2, t0 - 1, -1):
            # Λ_{t+1} (ŷˢ_{t+1} − ŷ_e,t+1) = d_{t+1} + Hᵀ w (z_{t+1} − H ŷˢ_{t+1}) (module doc);
            # only H ŷˢ_{t+1} = H ŷ_{t+1} + H δ_{t+1} enters, so the Rust pass keeps no
            # filtered states but the filtered rows (and ŷ_n for the start rows)
            wk = weights[t + 1][:, None]
            resid = zb[t + 1] - means[t + 1].reshape(width, n, nb)[:, 0, :]
            lam_e = carried.reshape(width, n, nb).copy()
            lam_e[:, 0, :] += np.where(wk > 0, resid * wk, 0.0)
            carried = _apply_block(a.T, lam_e.reshape(-1, nb), n)
            means[t] = filt[t] + cho_solve_banded((chols[t], False), carried)
        for t in range(t0):
            means[t] = means[t0]

    def image(states):
        est = np.empty_like(zb)
        for t in range(height):
            i = n - 1 - t if t < n else 0
            est[t] = np.einsum("a,lak->lk", lower[i], states[t].reshape(width, n, nb))
        return est[..., 0] if single else est

    return image(filt), (image(means) if smooth else None)


def scalar_nominal_error_map(
    rho,
    order,
    sigma,
    noise_var,
    shape,
    ar_order=None,
    plan=None,
    weights=None,
    row_models="propagated",
):
    """The error variance the causal quasi-optimal filter assumes: per pixel h_tᵀ [A_t⁻¹]_ℓℓ h_t,
    with A_t⁻¹ dense (twin of the Rust selected inversion; small grids only). weights: (H, W)
    per-pixel 1/σ_θ² (0 = missing), the systems of ``weighted_systems``."""
    height, width = shape
    n = order[0]
    if plan is None:
        plan = scalar_filter_plan(rho, order, sigma, noise_var, width, height, ar_order)
    _, lower = row_basis(rho[0], n)
    if weights is None:
        chols = [step["chol"] for step in plan[:height]]
    else:
        weights = np.asarray(weights, dtype=np.float64)
        chols = weighted_systems(plan[:height], lower, weights, row_models)
    out = np.empty((height, width))
    for t, (step, chol) in enumerate(zip(plan[:height], chols)):
        cov = cho_solve_banded((chol, False), np.eye(width * n))
        blocks = np.einsum("lalb->lab", cov.reshape(width, n, width, n))
        h = lower[step["index"]]
        out[t] = np.einsum("a,lab,b->l", h, blocks, h)
    return out


# ----------------------------------------------------------------------------------------------
# 4. exact MSE of a linear row estimator


def linear_estimator_mse(estimator, rho, order, sigma, noise_var, shape, chunk=1024):
    """Exact per-pixel MSE map of a linear estimator E (z ↦ E z, batch (H, W, B) in and out;
    E may also return a tuple of estimates, then a tuple of maps is returned): with
    x = Σ_c x_c ξ_c (x_c = σ (U_y√Λ_y)[:,a] ⊗ (U_x√Λ_x)[:,b]) and θ = √s Σ_q e_q η_q,
    MSE = Σ_c (E x_c − x_c)² + s Σ_q (E e_q)²."""
    height, width = shape
    ly, uy = eigh(axis_covariance(rho[0], order[0], height))
    lx, ux = eigh(axis_covariance(rho[1], order[1], width))
    ry, rx = uy * np.sqrt(np.clip(ly, 0, None)), ux * np.sqrt(np.clip(lx, 0, None))
    size = height * width
    maps = None
    for lo in range(0, size, chunk):
        idx = np.arange(lo, min(lo + chunk, size))
        a, b = np.divmod(idx, width)
        x = sigma * ry[:, None, a] * rx[None, :, b]  # (H, W, B)
        e = np.zeros((height, width, len(idx)))
        e[a, b, np.arange(len(idx))] = 1.0
        ex, ee = estimator(x), estimator(e)
        single = not isinstance(ex, tuple)
        ex, ee = ((ex,), (ee,)) if single else (ex, ee)
        parts = [
            np.sum((p - x) ** 2, axis=2) + noise_var * np.sum(q**2, axis=2) for p, q in zip(ex, ee)
        ]
        maps = parts if maps is None else [m + p for m, p in zip(maps, parts)]
    return maps[0] if single else tuple(maps)


def scalar_error_map(rho, order, sigma, noise_var, shape, ar_order=None, smooth=False):
    """Exact per-pixel MSE map of ``scalar_row_filter`` (via ``linear_estimator_mse``; it runs the
    filter on 2·H·W basis images, so keep it to small grids)."""
    plan = scalar_filter_plan(rho, order, sigma, noise_var, shape[1], shape[0], ar_order)
    return linear_estimator_mse(
        lambda z: scalar_row_filter(z, rho, order, sigma, noise_var, smooth=smooth, plan=plan),
        rho,
        order,
        sigma,
        noise_var,
        shape,
    )
