"""Study (not a library kernel): a rank-r error model per column for the quasi-optimal row
filter, the lead for the wide-band speed targets of issue 4 (design notes, *Row filters: speed*).

The quasi-optimal filter (§2.3 generalised) models the prediction error of all n_y rows
of each column's state; its row system has n_y unknowns per column and half-bandwidth
b = n_y(m+1) − 1 (11 for (3,3), 19 for (4,4)), so the solves cost ~2·b·n_y multiply-adds per
pixel. The optimal corrections P_e,j e₀ of the modes j span few directions of the n_y-row
state: in the raw basis the summed P_e of (4,4), ρ = 0.9, has eigenvalues 1 : 0.03 : 1e-4 :
8e-7. Here the error is modelled in the r leading directions only: V (n_y × r) = the leading
left singular vectors of [P_e,j e₀]_j, re-whitened inside the subspace (C = chol(Vᵀ R_y V):
the same model, better conditioned), the block AR(m) fitted to the band of the reduced
per-mode covariances, and each row solves r·W unknowns of half-bandwidth r(m+1) − 1 (7 for
(3,3) with r = 2, 14 for (4,4) with r = 3). Rows are predicted from the stationary prior of
the n_y rows above the image (the library's filter starts in information form instead; with
r = n_y the loss is the library filter's, ≤ 0.001 % for (4,4) here).

Smoothing. The naive reduced RTS, ŷˢ_t = ŷ_t + V_t A_t⁻¹ V_tᵀ Sᵀ V_{t+1}⁺ᵀ Λ_{t+1} V_{t+1}⁺
(ŷˢ_{t+1} − ŷ_e,t+1), fails when r < n_y (+18 % for (4,4) with r = 3 at ρ = 0.8,
σ_x²/σ_θ² = 10; it diverges with r = 2): V⁺ᵀ Vᵀ projects the adjoint onto span V_{t+1} and
drops its part along the observed row. The modified Bryson–Frazier form never inverts P_e:
with the model P_e,t = V Λ_t⁻¹ Vᵀ, G = H V, A_t = Λ_t + Gᵀ R⁻¹ G, the filter's gain is
K = V A⁻¹ Gᵀ R⁻¹ and its filtered covariance P_t = V A⁻¹ Vᵀ, so the MBF recursion

    λ̂_t = Sᵀ λ̃_{t+1},  δ_t = A_t⁻¹ V_tᵀ λ̂_t,  ŷˢ_t = ŷ_t + V_t δ_t,
    λ̃_t = λ̂_t + Hᵀ R⁻¹ (z_t − H ŷˢ_t)                 (λ̃_H = Hᵀ R⁻¹ (z_H − H ŷ_H))

(from λ̃_t = Hᵀ S_t⁻¹ ν_t + (I − K_t H)ᵀ λ̂_t and ŷˢ_t = ŷ_t + P_t λ̂_t, with S_t⁻¹ by
Woodbury) is the exact smoother of the model's covariances: one solve by A_t per row, as in
the library's smoothed pass, of which it is the rank-r form (r = n_y, V = I in the whitened
basis: the library's d_t is λ̂_t, and d_{t+1} + Hᵀ R⁻¹ (z − H ŷˢ_{t+1}) is λ̃_{t+1}).
Measured (2026-11-29, 32², the 12 cases of ``main``): (4,4) with r = 3 within +0.65 % of
the Wiener bound, (3,3) with r = 2 within +0.28 % at σ_x²/σ_θ² ≤ 1 but up to +6.4 % at 10;
where the naive pass failed, the MBF one holds (``main`` prints both).

Exact MSEs by linearity (``reference.row_filters.linear_estimator_mse``), against the optimal
filter's error map (causal) or the Wiener bound (smoothed). Run:
``python benches/study_reduced_rank.py`` (~8 min on the 2-vCPU VM).
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import splu

import kalmanfield as kf
from kalmanfield.reference.rowfilter import row_filters as ref


def reduced_plan(rho, order, noise_var, width, height, rank):
    """Per row: (state map V C (n × r), LU of A_t, Λ_t, left inverse of V C)."""
    n, m = order[0], max(order[1], 2)
    lam, u = ref.row_modes(rho[1], order[1], 1.0, width)
    a = ref.companion(rho[0], n)
    q = np.zeros((n, n))
    q[0, 0] = ref.beta_tilde_sq(rho[0], n)
    ry = ref.axis_covariance(rho[0], n, n)
    p = lam[:, None, None] * ry[None]  # the n rows above the image: stationary
    steps = []
    for _ in range(height):
        pe = a @ p @ a.T + lam[:, None, None] * q
        gain = pe[:, :, 0] / (pe[:, 0, 0] + noise_var)[:, None]
        p = pe - gain[:, :, None] * pe[:, 0, None, :]
        v = np.linalg.svd(pe[:, :, 0].T, full_matrices=False)[0][:, :rank]
        v = v @ np.linalg.cholesky(v.T @ ry @ v)
        vi = np.linalg.pinv(v)
        reduced = np.einsum("ai,lij,bj->lab", vi, pe, vi)
        band = ref.prediction_band(u, 0.5 * (reduced + reduced.transpose(0, 2, 1)), m)
        precision = ref.markov_precision(band, m, range(0))
        observed = sparse.kron(sparse.identity(width), np.outer(v[0], v[0]) / noise_var)
        steps.append((v, splu((precision + observed).tocsc()), precision.tocsr(), vi))
    return steps, a


def reduced_filter(zb, steps, a, noise_var, smooth=None):
    """The rank-r filter on a batch (H, W, B); smooth = None (causal), "mbf" or "naive"."""
    height, width, nb = zb.shape
    n = a.shape[0]
    state = np.zeros((width, n, nb))
    out = np.empty_like(zb)
    filtered, predicted = [], []
    for t in range(height):
        v, lu = steps[t][:2]
        state = np.einsum("ab,lbk->lak", a, state)
        predicted.append(state)
        rhs = v[0][None, :, None] * (zb[t] - state[:, 0, :])[:, None, :] / noise_var
        correction = lu.solve(rhs.reshape(-1, nb)).reshape(width, -1, nb)
        state = state + np.einsum("ia,lak->lik", v, correction)
        filtered.append(state)
        out[t] = state[:, 0, :]
    if smooth == "mbf":
        mbf_pass(zb, steps, a, noise_var, filtered, out)
    elif smooth == "naive":
        naive_rts_pass(steps, a, filtered, predicted, out)
    return out


def mbf_pass(zb, steps, a, noise_var, filtered, out):
    """The modified Bryson–Frazier pass (module doc) over the rows, from the last one up."""
    width, n, nb = filtered[-1].shape
    adjoint = np.zeros((width, n, nb))
    adjoint[:, 0, :] = (zb[-1] - filtered[-1][:, 0, :]) / noise_var
    for t in range(len(filtered) - 2, -1, -1):
        v, lu = steps[t][:2]
        adjoint = np.einsum("ba,lbk->lak", a, adjoint)  # λ̂_t = Sᵀ λ̃_{t+1}
        rhs = np.einsum("ia,lik->lak", v, adjoint).reshape(-1, nb)
        delta = lu.solve(rhs).reshape(width, -1, nb)
        smoothed = filtered[t] + np.einsum("ia,lak->lik", v, delta)
        adjoint[:, 0, :] += (zb[t] - smoothed[:, 0, :]) / noise_var
        out[t] = smoothed[:, 0, :]


def naive_rts_pass(steps, a, filtered, predicted, out):
    """The RTS pass with V⁺ᵀ Λ V⁺ in place of P_e⁻¹ (module doc: it fails for r < n_y)."""
    width, _, nb = filtered[-1].shape
    smoothed = filtered[-1]
    for t in range(len(filtered) - 2, -1, -1):
        _, _, precision, vi = steps[t + 1]
        v, lu = steps[t][:2]
        y = np.einsum("ai,lik->lak", vi, smoothed - predicted[t + 1]).reshape(-1, nb)
        y = np.einsum("ai,lak->lik", vi, (precision @ y).reshape(width, -1, nb))
        y = np.einsum("ia,lik->lak", v, np.einsum("ba,lbk->lak", a, y)).reshape(-1, nb)
        y = lu.solve(y).reshape(width, -1, nb)
        smoothed = filtered[t] + np.einsum("ia,lak->lik", v, y)
        out[t] = smoothed[:, 0, :]


def loss(order, rho, ratio, rank, shape=(32, 32), smooth=None):
    """Mean MSE of the rank-r filter over the optimal causal filter's (or, smoothed, over the
    Wiener bound), minus 1; σ_x² = 1, σ_θ² = 1/ratio."""
    noise_var, rr = 1.0 / ratio, (rho, rho)
    steps, a = reduced_plan(rr, order, noise_var, shape[1], shape[0], rank)
    mse = ref.linear_estimator_mse(
        lambda zb: reduced_filter(zb, steps, a, noise_var, smooth),
        rr,
        order,
        1.0,
        noise_var,
        shape,
    ).mean()
    model = kf.ARFieldModel(list(rr), list(order))
    if smooth:
        return mse / kf.wiener_bound(model, noise_var, shape) - 1
    return mse / kf.VectorRowFilter(model, noise_var, shape[1]).error_variance(shape[0]).mean() - 1


def main() -> None:
    print("causal, 32²: loss against the optimal row filter (target ≤ 3 %)")
    for order, rank in (((3, 3), 2), ((4, 4), 3), ((4, 4), 2)):
        for rho in (0.5, 0.8, 0.9, 0.95):
            row = [f"{100 * loss(order, rho, ratio, rank):+.3f} %" for ratio in (0.1, 1.0, 10.0)]
            print(f"  {order} r = {rank} ρ = {rho}: σ_x²/σ_θ² 0.1 / 1 / 10: {' / '.join(row)}")
    print("causal, 160 × 24 (does the loss grow down the image?)")
    for order, rank, rho in (((4, 4), 3, 0.9), ((3, 3), 2, 0.8), ((3, 3), 2, 0.95)):
        tall = loss(order, rho, 10.0, rank, (160, 24))
        print(f"  {order} r = {rank} ρ = {rho}, ratio 10: {100 * tall:+.3f} %")
    print("smoothed (MBF pass), 32²: gap to the Wiener bound (target ≤ 5 %)")
    for order, rank in (((3, 3), 2), ((4, 4), 3)):
        for rho in (0.5, 0.8, 0.9, 0.95):
            row = [
                f"{100 * loss(order, rho, ratio, rank, smooth='mbf'):+.3f} %"
                for ratio in (0.1, 1.0, 10.0)
            ]
            print(f"  {order} r = {rank} ρ = {rho}: σ_x²/σ_θ² 0.1 / 1 / 10: {' / '.join(row)}")
    print("smoothed, 160 × 24, ratio 10")
    for order, rank, rho in (((4, 4), 3, 0.9), ((3, 3), 2, 0.8), ((3, 3), 2, 0.95)):
        tall = loss(order, rho, 10.0, rank, (160, 24), smooth="mbf")
        print(f"  {order} r = {rank} ρ = {rho}: {100 * tall:+.3f} %")
    print("smoothed, naive reduced RTS against the MBF pass, 32²: gap to the Wiener bound")
    for order, rho, ratio in (((4, 4), 0.9, 1.0), ((4, 4), 0.8, 10.0), ((3, 3), 0.9, 1.0)):
        row = [
            f"r = {r}: {100 * loss(order, rho, ratio, r, smooth='naive'):+.3f} % / "
            f"{100 * loss(order, rho, ratio, r, smooth='mbf'):+.3f} %"
            for r in range(2, order[0] + 1)
        ]
        print(f"  {order} ρ = {rho} ratio {ratio}: {', '.join(row)}")


if __name__ == "__main__":
    main()
