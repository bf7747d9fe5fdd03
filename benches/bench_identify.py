"""Benchmark of ``kf.identify`` (method page *Identification*, §1.6): accuracy on simulated fields,
real images, speed.

1. Accuracy: fields of ``ARFieldModel([ρ, ρ], [n, n])`` on a 256² grid, n = 1..4,
   ρ ∈ {0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98}; both axes of every field are scored. Reported:
   the rate of correct multiplicity, the confusion of n for ρ ≥ 0.8, and the relative bias
   and RMSE of ρ̂ — for ``identify`` and for the source's route (§1.6 (2)): a 1-D
   Yule–Walker AR(n) fit on the pooled axis autocovariance, given the true n, and
   ρ = α_1 / n (the i = 1 term of ρ = (α_i / ((-1)^{i+1} C(n,i)))^{1/i}; the higher terms
   are even less stable).
2. Real images (scikit-image, if installed): the identified model and its time.
3. Speed: ``identify`` on a 2048² (2,3) field, one thread and all cores; the FFT
   ``sample_correlation`` (lags ±16) and a plain-NumPy implementation of the same statistics
   (``kalmanfield.reference.identification.kernels``) on the same image.

Run: ``python benches/bench_identify.py [--quick]``; the Markdown report is printed and
written to the benchmark page ``docs/benchmarks/identification.md`` (``--quick``: to
``bench_out/identification.md``).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np
from bench_page import write_page

import kalmanfield as kf
from kalmanfield import _core
from kalmanfield.reference.identification import kernels as ref

RHOS = (0.5, 0.6, 0.7, 0.8, 0.9, 0.95, 0.98)
ORDERS = (1, 2, 3, 4)
SIZE = 256


def source_rho(field: np.ndarray, axis: int, n: int) -> float:
    """ρ from the fitted AR(n) coefficients, the source's route (§1.6 (2))."""
    sums, counts = _core.lag_products(field - field.mean(), axis, n)
    c = sums / counts
    toeplitz = np.array([[c[abs(i - j)] for j in range(n)] for i in range(n)])
    alpha = np.linalg.solve(toeplitz, c[1 : n + 1])
    return float(alpha[0] / n)


def accuracy(reps: int) -> str:
    rows, confusion = [], np.zeros((4, 4), dtype=int)
    seed = 0
    for rho in RHOS:
        for n in ORDERS:
            right, err, err_src = 0, [], []
            for _ in range(reps):
                seed += 1
                x = kf.ARFieldModel([rho, rho], [n, n]).sample((SIZE, SIZE), seed=seed)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", RuntimeWarning)
                    fit = kf.identify(x)
                for axis, (r, m) in enumerate(zip(fit.rho, fit.order)):
                    right += m == n
                    err.append(r - rho)
                    err_src.append(source_rho(x, axis, n) - rho)
                    if rho >= 0.8:
                        confusion[n - 1, min(m, 4) - 1] += 1
            err, err_src = np.array(err) / rho, np.array(err_src) / rho
            rows.append(
                f"| {rho} | {n} | {right / (2 * reps):.3f} | {100 * err.mean():+.2f} | "
                f"{100 * np.sqrt(np.mean(err**2)):.2f} | {100 * err_src.mean():+.2f} | "
                f"{100 * np.sqrt(np.mean(err_src**2)):.2f} |"
            )
    total = confusion.trace() / confusion.sum()
    lines = [
        f"### Accuracy on simulated {SIZE}² fields ({reps} fields × 2 axes per cell)",
        "",
        "| ρ | n | n right | ρ bias % | ρ RMSE % | source route bias % | source route RMSE % |",
        "|---|---|---|---|---|---|---|",
        *rows,
        "",
        f"Confusion of n for ρ ≥ 0.8 (rows: true n, columns: identified n); "
        f"{100 * total:.1f} % right:",
        "",
        "| true \\ found | 1 | 2 | 3 | 4 |",
        "|---|---|---|---|---|",
        *[f"| {i + 1} | " + " | ".join(str(v) for v in confusion[i]) + " |" for i in range(4)],
    ]
    return "\n".join(lines)


def real_images() -> str:
    try:
        from skimage import data
    except ImportError:
        return "### Real images\n\nscikit-image is not installed: skipped."
    rows = []
    for name in ("camera", "brick", "grass", "gravel", "astronaut", "coins", "moon"):
        image = getattr(data, name)()
        start = time.perf_counter()
        fit = kf.identify(image, axes=(0, 1))
        elapsed = time.perf_counter() - start
        rows.append(
            f"| {name} | {image.shape} {image.dtype} | {fit.order} | "
            f"({fit.rho[0]:.4f}, {fit.rho[1]:.4f}) | {fit.variance:.1f} | {fit.mean:.1f} | "
            f"{1e3 * elapsed:.0f} |"
        )
    return "\n".join(
        [
            "### Real images (scikit-image; colour channels are replicates: axes=(0, 1))",
            "",
            "| image | shape | n (y, x) | ρ (y, x) | σ² | mean | ms |",
            "|---|---|---|---|---|---|---|",
            *rows,
        ]
    )


def best_time(f, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - start)
    return best


def speed(repeats: int) -> str:
    x = kf.ARFieldModel([0.9, 0.8], [2, 3]).sample((2048, 2048), seed=1)
    one = best_time(lambda: kf.identify(x, threads=1), repeats)
    every = best_time(lambda: kf.identify(x), repeats)
    fft = best_time(lambda: kf.sample_correlation(x, 16), repeats)

    def numpy_statistics():
        c = x - x.mean()
        for axis in (0, 1):
            ref.difference_gram(c, axis, 4)
            ref.lag_products(c, axis, 16)

    def rust_statistics():
        c = x - x.mean()
        for axis in (0, 1):
            _core.difference_gram(c, axis, 4, 1)
            _core.lag_products(c, axis, 16, 1)

    numpy_time = best_time(numpy_statistics, 1)
    rust_time = best_time(rust_statistics, repeats)
    return "\n".join(
        [
            "### Speed, 2048² float64 (2,3) field",
            "",
            "| what | time (s) |",
            "|---|---|",
            f"| `identify`, 1 thread | {one:.3f} |",
            f"| `identify`, {os.cpu_count()} threads | {every:.3f} |",
            f"| `sample_correlation(x, 16)` (FFT, full 2-D, 33×33 lags) | {fft:.3f} |",
            f"| difference Grams + lag products of both axes, Rust, 1 thread | {rust_time:.3f} |",
            f"| the same statistics, NumPy reference | {numpy_time:.3f} "
            f"({numpy_time / rust_time:.0f}× slower) |",
        ]
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="4 fields per cell, 1 repeat")
    args = parser.parse_args()
    reps = 4 if args.quick else 25
    report = "\n\n".join(
        [
            accuracy(reps),
            real_images(),
            speed(1 if args.quick else 5),
        ]
    )
    print(report)
    write_page("identification", "Benchmark: identification", report, full_run=not args.quick)


if __name__ == "__main__":
    main()
