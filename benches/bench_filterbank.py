"""Speed of the Kalman filter bank (``kalmanfield.TypeIdentifier``) against vectorised
NumPy banks, and the source's claims on type confusion [I] (method page *Kalman filter
bank*). Writes ``docs/benchmarks/filterbank.md`` and ``docs/images/filterbank_confusion.png``.

Speed: B trajectories × N frames × 4 models (two Markov-velocity, two Singer types; 2-D
positions; no missed frames), the per-frame decisions (maximum posterior) and accumulated
log-likelihoods of every trajectory. Competitors, each over all trajectories at once with
the covariance recursion computed once per model (shared by all trajectories, as the Rust
bank shares it):

1. ``twin``: ``kalmanfield.reference.filterbank.bank_run``, a loop over frames and models
   of (B, n) matrix products;
2. ``stacked``: the four models stacked into one block-diagonal state (Σn = 20), one loop
   over frames with four (B, ·) matrix products per frame for all models;
3. ``whitening map``: the innovations are a fixed linear map of the measurements, so per
   model the whitened innovations of all frames are one (B, N m) × (N m, N m) product
   (BLAS) — O(N²) work per trajectory instead of O(N), but one call.

Time: wall-clock, best of ``--repeats`` (NumPy: the better of the default BLAS threads and
one BLAS thread, when threadpoolctl is installed); outputs cross-checked (decisions equal,
log-likelihoods to 1e-8 relative). Claims: ``kalmanfield.experiments.type_confusion`` on a
grid of parameters (1,000 runs per type).

Run: ``python benches/bench_filterbank.py [--quick]``; the report is printed and written to
the benchmark page ``docs/benchmarks/filterbank.md`` with the plot
``docs/images/filterbank_confusion.png`` (``--quick``: small sizes, no plot, the page to
``bench_out/filterbank.md``; a test calls it; other non-default sizes: page and plot to
``bench_out/``).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from bench_page import ROOT, SCRATCH, write_page

import kalmanfield as kf
from kalmanfield.experiments import ACCELERATION, VELOCITY, source_banks, type_confusion
from kalmanfield.reference import filterbank as ref
from kalmanfield.reference.kalman import LN_2PI, gain, predict


def four_types() -> list[kf.LinearGaussianModel]:
    return [
        kf.LinearGaussianModel.markov_velocity(1.0, 0.98, 0.5, 2, 0.5, name="calm_v"),
        kf.LinearGaussianModel.markov_velocity(1.0, 0.7, 2.0, 2, 0.5, name="agile_v"),
        kf.LinearGaussianModel.singer(1.0, 0.95, 0.1, 2, 0.5, name="calm_a"),
        kf.LinearGaussianModel.singer(1.0, 0.6, 0.8, 2, 0.5, name="agile_a"),
    ]


def schedules(models, frames):
    """Per model and frame: (K, S⁻¹, ln det S + m ln 2π), the shared covariance recursion."""
    out = []
    for f, q, h, r, _, p0 in (m.arrays() for m in models):
        cov, per_frame = p0, []
        for _ in range(frames):
            _, cov = predict(f, q, np.zeros(len(p0)), cov)
            k, precision, log_det, cov = gain(h, r, cov)
            per_frame.append((k, precision, log_det + h.shape[0] * LN_2PI))
        out.append(per_frame)
    return out


def numpy_stacked(z, models):
    """All models in one block-diagonal state; four products per frame."""
    b, frames, m = z.shape
    arrays = [mod.arrays() for mod in models]
    sizes = [len(a[4]) for a in arrays]
    n, k_models = sum(sizes), len(models)
    big_f, big_h = np.zeros((n, n)), np.zeros((k_models * m, n))
    start = 0
    for i, (f, _, h, _, _, _) in enumerate(arrays):
        big_f[start : start + sizes[i], start : start + sizes[i]] = f
        big_h[i * m : (i + 1) * m, start : start + sizes[i]] = h
        start += sizes[i]
    sched = schedules(models, frames)
    x = np.tile(np.concatenate([a[4] for a in arrays]), (b, 1))
    ll = np.zeros((b, frames, k_models))
    total = np.zeros((b, k_models))
    for t in range(frames):
        big_k = np.zeros((n, k_models * m))
        big_p = np.zeros((k_models * m, k_models * m))
        offsets = np.empty(k_models)
        start = 0
        for i in range(k_models):
            k, precision, offsets[i] = sched[i][t]
            big_k[start : start + sizes[i], i * m : (i + 1) * m] = k
            big_p[i * m : (i + 1) * m, i * m : (i + 1) * m] = precision
            start += sizes[i]
        x = x @ big_f.T
        nu = np.tile(z[:, t], k_models) - x @ big_h.T
        x += nu @ big_k.T
        quad = ((nu @ big_p) * nu).reshape(b, k_models, m).sum(axis=2)
        total -= 0.5 * (quad + offsets)
        ll[:, t] = total
    return np.argmax(ll, axis=2), ll


def whitening_map(model, frames):
    """(W, c, offsets): whitened innovations w = z_flat @ W.T − c for all frames."""
    f, q, h, r, x0, p0 = model.arrays()
    m, n = h.shape
    sched = schedules([model], frames)[0]
    # the predicted mean is x̄_t = A_t x̄_(t−1) + B_t z_(t−1): track its coefficients
    coef = np.zeros((n, frames * m))
    mean = f @ x0
    w_rows, c_rows = [], []
    for t in range(frames):
        k, precision, _ = sched[t]
        root = np.linalg.cholesky(precision)  # S⁻¹ = L Lᵀ, so |Lᵀ ν|² = νᵀ S⁻¹ ν
        e = np.zeros((m, frames * m))
        e[:, t * m : (t + 1) * m] = np.eye(m)
        nu_coef, nu_const = e - h @ coef, -(h @ mean)
        w_rows.append(root.T @ nu_coef)
        c_rows.append(-(root.T @ nu_const))
        coef, mean = f @ (coef + k @ nu_coef), f @ (mean + k @ nu_const)
    offsets = np.array([s[2] for s in sched])
    return np.vstack(w_rows), np.concatenate(c_rows), offsets


def numpy_whitening(z, models, maps=None):
    b, frames, m = z.shape
    flat = z.reshape(b, frames * m)
    ll = np.empty((b, frames, len(models)))
    maps = maps or [whitening_map(mod, frames) for mod in models]
    for i, (w, c, offsets) in enumerate(maps):
        white = flat @ w.T - c
        quad = (white**2).reshape(b, frames, m).sum(axis=2)
        ll[:, :, i] = np.cumsum(-0.5 * (quad + offsets), axis=1)
    return np.argmax(ll, axis=2), ll


def blas_single(fn: Callable[[], float]) -> float:
    """`fn()` with BLAS limited to one thread (threadpoolctl, if installed; else inf)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return float("inf")
    with threadpool_limits(limits=1, user_api="blas"):
        return fn()


def best_time(fn: Callable[[], object], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return min(times)


def speed(n_traj: int, frames: int, repeats: int) -> tuple[list[str], float]:
    models = four_types()
    per = -(-n_traj // 4)
    z = np.concatenate([m.simulate(frames, per, seed=i)[1] for i, m in enumerate(models)])
    z = np.ascontiguousarray(z[:n_traj])
    arrays = [m.arrays() for m in models]

    def rust(threads=None, keep=True):
        return kf.TypeIdentifier(models).run(z, return_log_likelihoods=keep, threads=threads)

    decisions, ll = rust()
    for name, out in [
        ("twin", ref.bank_run(z, arrays)),
        ("stacked", numpy_stacked(z, models)),
        ("whitening", numpy_whitening(z, models)),
    ]:
        np.testing.assert_allclose(out[1], ll, rtol=1e-8, atol=1e-6, err_msg=name)
        agree = (out[0] == decisions).mean()
        assert agree > 0.9999, (name, agree)
    maps = [whitening_map(m, frames) for m in models]
    timings = {
        "Rust, all cores (decisions + log-likelihoods)": best_time(rust, repeats),
        "Rust, all cores (decisions only)": best_time(lambda: rust(keep=False), repeats),
        "Rust, 1 thread (decisions + log-likelihoods)": best_time(lambda: rust(1), repeats),
    }
    competitors = {
        "NumPy twin (loop over frames and models)": lambda: ref.bank_run(z, arrays),
        "NumPy stacked (one block-diagonal state)": lambda: numpy_stacked(z, models),
        "NumPy whitening map (BLAS, map precomputed)": lambda: numpy_whitening(z, models, maps),
    }
    for name, fn in competitors.items():
        # the better of the default BLAS threads and one BLAS thread (small products on a
        # shared machine often run faster without BLAS's thread pool)
        single = blas_single(lambda fn=fn: best_time(fn, repeats))
        timings[name] = min(best_time(fn, repeats), single)
    rust_time = timings["Rust, all cores (decisions + log-likelihoods)"]
    best_numpy = min(v for k, v in timings.items() if k.startswith("NumPy"))
    lines = [
        f"{n_traj:,} trajectories × {frames} frames × 4 models (2-D, no missed frames); "
        f"best of {repeats}.",
        "",
        "| method | time (ms) | time / Rust (all cores) |",
        "|---|---:|---:|",
    ]
    for name, t in timings.items():
        lines.append(f"| {name} | {1e3 * t:.1f} | {t / rust_time:.2f} |")
    ratio = best_numpy / rust_time
    lines += ["", f"Rust (all cores) vs the best NumPy bank: **{ratio:.1f}×** faster."]
    return lines, ratio


GRID = [
    ((0.9, 0.5), 0.1, 3.0),
    ((0.9, 0.5), 0.1, 1.0),
    ((0.9, 0.5), 0.3, 1.0),
    ((0.9, 0.5), 1.0, 1.0),
    ((0.5, 0.0), 0.1, 3.0),
    ((0.5, 0.0), 0.3, 1.0),
    ((0.95, 0.8), 0.1, 3.0),
    ((0.95, 0.8), 0.3, 1.0),
]
FRAMES_SHOWN = [1, 10, 25, 50, 100]


def claims(runs: int, frames: int) -> list[str]:
    lines = [
        f"Confusion probability (maximum posterior, equal priors) after k frames, {runs:,} "
        "runs per type (Wilson 95 % half-width ≤ "
        f"{100 * 1.96 * np.sqrt(0.25 / (2 * runs)):.1f} points); v = velocity types "
        "([I] eq. 7), a = velocity + acceleration types (eq. 8); ratio = v / a.",
        "",
    ]
    shown = [k for k in FRAMES_SHOWN if k <= frames]
    lines += [
        "| ρ₁, ρ₂ | driving std | σ_z | " + " | ".join(f"k = {k}" for k in shown) + " |",
        "|---|---:|---:|" + "---|" * len(shown),
    ]
    for rho, w, sz in GRID:
        result = type_confusion(source_banks(rho, w, sz), frames, runs, progress=False)
        v, a = result.confusion(VELOCITY), result.confusion(ACCELERATION)
        cells = []
        for k in shown:
            ratio = v[k] / a[k] if a[k] > 0 else float("inf")
            cells.append(f"v {v[k]:.3f} / a {a[k]:.3f} ({ratio:.1f}×)")
        lines.append(f"| {rho[0]}, {rho[1]} | {w} | {sz} | " + " | ".join(cells) + " |")
    return lines


def plot(path: Path, runs: int, frames: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, (rho, w, sz) in zip(axes, [GRID[0], GRID[3]]):
        type_confusion(source_banks(rho, w, sz), frames, runs, progress=False).plot(ax)
        ax.set_title(f"ρ = {rho}, driving std {w}, σ_z = {sz}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=80)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--trajectories", type=int, default=10_000)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--runs", type=int, default=1000)
    args = parser.parse_args()
    full_run = not args.quick and vars(args) == vars(parser.parse_args([]))
    if args.quick:
        args.trajectories, args.frames, args.repeats, args.runs = 64, 12, 1, 20
    speed_lines, _ = speed(args.trajectories, args.frames, args.repeats)
    print("\n".join(speed_lines))
    claim_lines = claims(args.runs, args.frames)
    print("\n".join(claim_lines))
    report = ["## Speed", "", *speed_lines, "", "## The source's claims", "", *claim_lines]
    if not args.quick:
        images = ROOT / "docs" / "images" if full_run else SCRATCH
        images.mkdir(parents=True, exist_ok=True)
        plot(images / "filterbank_confusion.png", args.runs, args.frames)
        report += ["", "![confusion vs frame](../images/filterbank_confusion.png)"]
    write_page("filterbank", "Benchmark: Kalman filter bank", "\n".join(report), full_run=full_run)


if __name__ == "__main__":
    main()
