"""Study (not a library kernel): fit the band to the *filtered* covariance and predict exactly,
the lead for the quasi-optimal filter's losses at high SNR (benchmark page *Row filters*,
"High SNR").

The quasi-optimal filter (§2.3 generalised) fits a block AR(m) along the row (a banded
precision, the maximum-entropy completion of the band) to the prediction error P_e,t of the n_y
rows in its state. At high SNR P_e,t = S P_f,t−1 Sᵀ + Q is the sum of a smooth part (the
innovation Q, whose precision is banded) and a near-white part (the filtered error of the row
above, ~σ_θ²): its precision is far from banded, and widening the band hardly helps ((1,2),
ρ = 0.99, σ_x²/σ_θ² = 1e4: +16 % at m = 2, +11 % at m = 8 on 32²).

The variant here fits the band to P_f,t−1 instead (a banded precision Λ̃_t−1 ≈ P_f,t−1⁻¹)
and predicts exactly from it, P_e,t = S Λ̃_t−1⁻¹ Sᵀ + Q. Computed densely here; in a row
filter the update would be one banded solve of the joint system of (row t, the n_y rows of
the state at t − 1), whose precision [[Q₀⁻¹, −Q₀⁻¹ a], [−aᵀ Q₀⁻¹, Λ̃ + aᵀ Q₀⁻¹ a]] is banded
(Q₀ = β̃² R_x, a the AR(n_y) coefficients along y): (n_y + 1) W unknowns per row instead of
n_y W, and the band of the new state's P_f (the oldest row marginalised) from that system's
factor by selected inversion, as the propagated row models already do.

Both filters start exact on the first n_y rows (conditioned on all of them; the library's start
differs on rows < n_y − 1, which are left out) and fit every row to the optimal filter's
covariance (no settling rule). Each one's exact error covariance is propagated,
E_t = G_t (S E_t−1 Sᵀ + Q) G_tᵀ + σ_θ⁻² K_t Hᵀ H K_t, G_t = K_t Λ_t, K_t = (Λ_t + HᵀH/σ_θ²)⁻¹,
and the loss is the mean MSE of the newest row over rows n_y … H − 1 against the optimal
filter's. The ``Pe-band`` column is the library's model (its causal loss on the same grid, in
the high-SNR table of the benchmark page *Row filters*, is within rounding of it where the
settling rule does not bind). Dense NumPy, so (3,3) stops at ρ = 0.95 and (4,4) at 0.9
(beyond, these float64 inverses break down). Run: ``python benches/study_filtered_band.py``
(~1 min on the 2-vCPU VM).
"""

from __future__ import annotations

import itertools

import numpy as np

from kalmanfield.reference.rowfilter import row_filters as ref

SIZE = 48
CASES = {
    "orders": ((1, 1), (1, 2), (2, 1), (2, 2), (3, 3), (4, 4)),
    "rhos": (0.9, 0.95, 0.99),
    "ratios": (1.0, 100.0, 1e4),
}


def dynamics(rho: float, order: tuple[int, int], width: int, noise_var: float):
    """(S, Q, H, P_f,start) in the whitened row basis (v = (T ⊗ I) X, X the n_y rows newest
    first, T = L⁻¹, L Lᵀ the rows' correlation; the block fits are unchanged by it, and for
    n_y ≥ 3 at ρ = 0.99 the raw basis is singular in float64): the transition, the innovation
    covariance, the readout of the newest row and the filtered covariance given the first
    n_y rows (σ_x = 1)."""
    n = order[0]
    rx = ref.axis_covariance(rho, order[1], width)
    ty = ref.axis_covariance(rho, n, n + 1)
    phi = np.linalg.solve(ty[:n, :n], ty[1:, 0])  # x_t = Σ_k φ_k x_{t−k} + w
    innovation = ty[0, 0] - phi @ ty[1:, 0]
    a = np.zeros((n, n))
    a[0] = phi
    a[1:, :-1] = np.eye(n - 1)
    lower = np.linalg.cholesky(ty[:n, :n])
    tmat = np.linalg.inv(lower)
    eye = np.eye(width)
    s = np.kron(tmat @ a @ lower, eye)
    q = innovation * np.kron(np.outer(tmat[:, 0], tmat[:, 0]), rx)
    h = np.kron(lower[:1], eye)
    observed = np.kron(lower.T @ lower, eye) / noise_var
    start = np.linalg.inv(np.kron(np.eye(n), np.linalg.inv(rx)) + observed)
    return s, q, h, start


def column_blocks(n: int, width: int) -> np.ndarray:
    """Permutation from the row-major state (row, column) to column-major (column, row)."""
    return np.arange(n * width).reshape(n, width).T.ravel()


def max_entropy(cov: np.ndarray, n: int, width: int, m: int) -> np.ndarray:
    """Banded precision (block bandwidth m over columns of n rows) whose inverse matches `cov`
    on the band: the block AR(m) fit along the row (covariance selection)."""
    perm = column_blocks(n, width)
    c = cov[np.ix_(perm, perm)]
    lam = np.zeros_like(c)
    for j in range(max(width - m, 1)):
        w = slice(j * n, min(j + m + 1, width) * n)
        lam[w, w] += np.linalg.inv(c[w, w])
    for j in range(1, width - m):
        w = slice(j * n, (j + m) * n)
        lam[w, w] -= np.linalg.inv(c[w, w])
    out = np.empty_like(lam)
    out[np.ix_(perm, perm)] = lam
    return out


def losses(order: tuple[int, int], rho: float, ratio: float, m: int, size: int = SIZE):
    """{'Pe-band': loss %, 'Pf-band': loss %} of the two quasi-optimal filters, causal."""
    n, width, noise_var = order[0], size, 1.0 / ratio
    s, q, h, start = dynamics(rho, order, width, noise_var)
    obs = h.T @ h / noise_var
    optimal, filtered, mse = [], [start], {"Pe-band": [], "Pf-band": []}
    errors = {key: start for key in mse}
    for _ in range(n, size):
        prediction = s @ filtered[-1] @ s.T + q
        precisions = {
            "Pe-band": max_entropy(prediction, n, width, m),
            "Pf-band": np.linalg.inv(
                s @ np.linalg.inv(max_entropy(filtered[-1], n, width, m)) @ s.T + q
            ),
        }
        filtered.append(np.linalg.inv(np.linalg.inv(prediction) + obs))
        optimal.append(np.trace(h @ filtered[-1] @ h.T))
        for key, lam in precisions.items():
            k = np.linalg.inv(lam + obs)
            g = k @ lam
            errors[key] = g @ (s @ errors[key] @ s.T + q) @ g.T + k @ obs @ k.T
            mse[key].append(np.trace(h @ errors[key] @ h.T))
    return {key: 100 * (sum(v) / sum(optimal) - 1) for key, v in mse.items()}


def main() -> None:
    """Print the loss table (Markdown) over CASES."""
    print(f"Causal loss % against the optimal filter, {SIZE}², rows n_y … {SIZE - 1}")
    print("| (n_y,n_x) | ρ | σ_x²/σ_θ² | m | Pe-band (library) | Pf-band + exact prediction |")
    print("|---|---|---|---|---:|---:|")
    for order, rho, ratio in itertools.product(*CASES.values()):
        if rho > (0.95 if order[0] == 3 else 0.9 if order[0] == 4 else 1.0):
            continue  # the dense float64 inverses here break down (the library's do not)
        m = max(order[1], 2)
        r = losses(order, rho, ratio, m)
        print(
            f"| {order} | {rho} | {ratio:g} | {m} | {r['Pe-band']:+.2f} | {r['Pf-band']:+.3f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
