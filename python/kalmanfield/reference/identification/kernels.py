"""NumPy reference of the identification kernels (method page *Identification*, §1.6): twins of the
Rust modules difference_gram, lag_products and whitening, and a direct-sum sample correlation
(the public one uses FFTs). Missing values are NaN, as in the kernels."""

from __future__ import annotations

import itertools

import numpy as np


def difference_gram(data: np.ndarray, axis: int, max_order: int) -> tuple[np.ndarray, int]:
    """G_ab = Σ Dᵃx Dᵇx over the positions where D^M x is finite (D = 1 - z⁻¹ along `axis`)."""
    x = np.moveaxis(np.asarray(data, dtype=np.float64), axis, -1)
    diffs = [x]
    for _ in range(max_order):
        diffs.append(np.diff(diffs[-1], axis=-1))
    aligned = [d[..., max_order - m :] for m, d in enumerate(diffs)]
    ok = np.isfinite(aligned[-1])
    gram = np.array([[np.sum((a * b)[ok]) for b in aligned] for a in aligned])
    return gram, int(ok.sum())


def lag_products(data: np.ndarray, axis: int, max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """S_h = Σ x_i x_{i+h} and the number of finite pairs, h = 0..max_lag, along `axis`."""
    x = np.moveaxis(np.asarray(data, dtype=np.float64), axis, -1)
    sums, counts = np.zeros(max_lag + 1), np.zeros(max_lag + 1, dtype=np.uint64)
    for h in range(min(max_lag, x.shape[-1] - 1) + 1):
        p = x[..., : x.shape[-1] - h] * x[..., h:]
        ok = np.isfinite(p)
        sums[h], counts[h] = p[ok].sum(), ok.sum()
    return sums, counts


def whiten_axis(data: np.ndarray, axis: int, rho: float, order: int) -> np.ndarray:
    """(1 - ρ z⁻¹)ⁿ x along `axis` by the binomial expansion Σ_j (-ρ)^j C(n,j) x_{i-j};
    the first n elements of every line are NaN."""
    x = np.moveaxis(np.asarray(data, dtype=np.float64), axis, -1)
    out = np.full(x.shape, np.nan)
    length = x.shape[-1]
    if length > order:
        acc = np.zeros(x[..., order:].shape)
        for j in range(order + 1):
            coeff = float(np.prod([(order - i) / (i + 1) for i in range(j)])) * (-rho) ** j
            acc = acc + coeff * x[..., order - j : length - j]
        out[..., order:] = acc
    return np.moveaxis(out, -1, axis)


def sample_correlation(data: np.ndarray, max_lag: tuple[int, ...], unbiased: bool = True):
    """R̂(h̄) by direct sums over the pairs of finite pixels, centred layout (2L+1, …)."""
    x = np.asarray(data, dtype=np.float64)
    ok = np.isfinite(x)
    c = np.where(ok, x - x[ok].mean(), 0.0)
    out = np.empty(tuple(2 * lag + 1 for lag in max_lag))
    for h in itertools.product(*[range(-lag, lag + 1) for lag in max_lag]):
        a = tuple(slice(max(0, -d), n - max(0, d)) for d, n in zip(h, x.shape))
        b = tuple(slice(max(0, d), max(0, d) + (s.stop - s.start)) for d, s in zip(h, a))
        pairs = (ok[a] & ok[b]).sum()
        total = np.sum(c[a] * c[b])
        norm = pairs if unbiased else ok.sum()
        out[tuple(lag + d for lag, d in zip(max_lag, h))] = total / norm if pairs else np.nan
    return out / out[tuple(max_lag)]
