"""Benchmark of the sequence filter (method page *Sequence filter*, §2.5.1–2.5.3): the gains
of filtering in time over the per-frame Wiener bound, the fast filter's loss against the
exact one, and the fast filter's speed against the frame-by-frame ScalarRowFilter.

Run: ``python benches/bench_sequence.py [--quick]``; the report is printed and written to
``docs/benchmarks/sequence.md`` (``--quick``: smaller grids and fewer frames, to bench_out/).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_page import write_page  # noqa: E402

import kalmanfield as kf  # noqa: E402


def db(reference: float, value: float) -> float:
    return 10 * np.log10(reference / value)


def monte_carlo(model, noise_var, side, frames, warmup, seed, methods):
    """Per method, the MSE over frames warmup.. of one long sequence (the same noisy frames
    for every method: the ratios between methods are paired)."""
    rng = np.random.default_rng(seed)
    x = model.sample((frames, side, side), seed=int(rng.integers(2**32)))
    z = x + np.sqrt(noise_var) * rng.normal(size=x.shape)
    out = {}
    for method in methods:
        f = kf.SequenceFilter(model, noise_var, (side, side), method=method)
        estimate = f.filter(z)
        out[method] = float(np.mean((estimate[warmup:] - x[warmup:]) ** 2))
    return out


def gains(quick: bool) -> str:
    lines = [
        "## Gains over the per-frame Wiener bound",
        "",
        "Spatial (2,2), ρ = 0.9, σ_θ² = σ_x² = 1, n_t = 1. Bound and exact filter: analytic, "
        "32² frames (the per-frame Wiener bound, `wiener_bound`, against the exact filter's "
        "steady error map); smoothers: the exact fixed-lag smoother's map; fast: Monte Carlo, "
        "the fast and exact filters on the same noisy frames, MSE after the warm-up, fast's "
        "gain = exact gain − its measured loss.",
        "",
        "| ρ_t | exact causal | lag 1 | lag 3 | lag 10 | fast (measured) | fast / exact MSE |",
        "|---|---|---|---|---|---|---|",
    ]
    side = 32
    bound = kf.wiener_bound(kf.ARFieldModel((0.9, 0.9), (2, 2)), 1.0, (side, side))
    for rho_t in (0.5, 0.9, 0.95, 0.99):
        model = kf.ARFieldModel((rho_t, 0.9, 0.9), (1, 2, 2))
        errors = [
            kf.SequenceFilter(model, 1.0, (side, side), lag=lag).error_variance().mean()
            for lag in (0, 1, 3, 10)
        ]
        frames, warmup = (150, 50) if quick else (300, 100)
        mc = monte_carlo(model, 1.0, 48, frames, warmup, 1, ("optimal", "fast"))
        loss = mc["fast"] / mc["optimal"]
        cells = [f"{db(bound, e):.2f} dB" for e in errors]
        fast_gain = db(bound, errors[0]) - 10 * np.log10(loss)
        lines.append(f"| {rho_t} | {' | '.join(cells)} | {fast_gain:.2f} dB | {loss:.3f} |")
    return "\n".join(lines)


def quality_grid(quick: bool) -> str:
    lines = [
        "## The fast filter against the exact one",
        "",
        "MSE ratio fast / exact, Monte Carlo on the same noisy frames (48², "
        + ("100 frames after 40 of warm-up" if quick else "160 frames after 60 of warm-up")
        + "; paired, so the ratio's SE is well below 1 %). Spatial ρ = 0.9.",
        "",
        "| n_t | ρ_t | spatial | σ_θ²/σ_x² = 0.1 | 1 | 10 |",
        "|---|---|---|---|---|---|",
    ]
    frames, warmup = (140, 40) if quick else (220, 60)
    worst = 0.0
    for n_t in (1, 2):
        for rho_t in (0.5, 0.9, 0.99):
            for spatial in ((1, 1), (2, 2)):
                try:
                    model = kf.ARFieldModel((rho_t, 0.9, 0.9), (n_t, *spatial))
                except ValueError as err:  # (a start beyond float64)
                    lines.append(f"| {n_t} | {rho_t} | {spatial} | {err} | | |")
                    continue
                cells = []
                for ratio in (0.1, 1.0, 10.0):
                    mc = monte_carlo(model, ratio, 48, frames, warmup, 2, ("optimal", "fast"))
                    r = mc["fast"] / mc["optimal"]
                    worst = max(worst, r)
                    cells.append(f"{r:.3f}")
                lines.append(f"| {n_t} | {rho_t} | {spatial} | {' | '.join(cells)} |")
    lines += ["", f"Worst ratio: {worst:.3f}."]
    return "\n".join(lines)


def speed(quick: bool) -> str:
    side = 512 if quick else 1024
    model = kf.ARFieldModel((0.95, 0.9, 0.9), (1, 2, 2))
    planar = kf.ARFieldModel((0.9, 0.9), (2, 2))
    rng = np.random.default_rng(3)
    z = rng.normal(size=(8, side, side))
    fast = kf.SequenceFilter(model, 1.0, (side, side), method="fast", threads=1)
    rows = {
        "ScalarRowFilter, causal": kf.ScalarRowFilter(planar, 1.0, side, threads=1),
        "ScalarRowFilter, smoothed": kf.ScalarRowFilter(planar, 1.0, side, smooth=True, threads=1),
    }
    timings = {}
    for name, f in rows.items():
        for frame in z[:2]:
            f.filter(frame)
        start = time.perf_counter()
        for frame in z[2:]:
            f.filter(frame)
        timings[name] = (time.perf_counter() - start) / (len(z) - 2)
    for frame in z[:2]:  # (frame 0 runs the field's row filter, frame 1 plans the steady one)
        fast.step(frame)
    start = time.perf_counter()
    for frame in z[2:]:
        fast.step(frame)
    timings["SequenceFilter, fast"] = (time.perf_counter() - start) / (len(z) - 2)
    base = timings["ScalarRowFilter, causal"]
    lines = [
        f"## Speed, {side}² frames, one thread",
        "",
        "Per frame, after two frames that build the plans; the same run.",
        "",
        "| filter | ms per frame | × causal ScalarRowFilter |",
        "|---|---|---|",
    ]
    for name, t in timings.items():
        lines.append(f"| {name} | {1e3 * t:.1f} | {t / base:.2f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    parts = [gains(args.quick), quality_grid(args.quick), speed(args.quick)]
    text = "\n\n".join(parts)
    print(text)
    write_page("sequence", "Benchmark: sequence filter", text, full_run=not args.quick)


if __name__ == "__main__":
    main()
