"""Benchmark of the row Kalman filters (method page *Row filters*, §2): exact losses, speed,
real-image denoising.

1. Loss table — exact mean MSEs, no Monte Carlo, on an H = W grid (48², ``--quick``: 32² and
   fewer cases) for (n_y, n_x) ∈ {(1,1), (2,2), (3,3), (4,4), (1,2), (2,1)},
   ρ_y = ρ_x ∈ {0.5, 0.8, 0.9, 0.95}, σ_x²/σ_θ² ∈ {0.1, 1, 10} (σ_x = 1):
   - optimal causal: ``VectorRowFilter.error_variance(H).mean()`` (§2.1–2.2);
   - scalar causal / smoothed: ``ScalarRowFilter`` (§2.3 generalised), exact MSE from
     the filter run on the H·W orthonormal eigen-images of Cov(x) (white noise shares that
     basis); cross-checked in every run against ``reference.row_filters.linear_estimator_mse``
     (the filter run on 2·H·W basis images);
   - loss % = scalar causal / optimal causal − 1 (target ≤ 3 %);
   - gap % = scalar smoothed / ``wiener_bound`` − 1 (target ≤ 5 %);
   - for (1,1): §2.3's literal scheme, ``ScalarRowFilter(..., ar_order=1)``, causal.
2. Speed, one thread unless stated, best of 3 (``time.perf_counter``), the per-height plan
   built by a warm-up call and not timed: ``ScalarRowFilter`` on 2048² for (1,1), (2,2),
   (3,3), (4,4), causal and smoothed, and for every (n_y, n_x) ≤ (4, 4); the NumPy
   reference ``scalar_row_filter`` against the Rust one on 256²; ``VectorRowFilter``
   construction (eigendecomposition) and filter at width 1024; optimal / quasi-optimal time
   ratio against the width; ``ScalarRowFilter`` set-up
   (construction + the plan of a 64-row image) with the band from the spliced ends (the
   default ``modes="ends"``) and from the whole row's eigenbasis (``"exact"``) at widths
   1024–4096, with the largest difference of their outputs; a stack of 8 frames of 512² on one
   thread, on an explicit pool of all cores and on the default global pool (threads=None);
   one image with threads=1 against the default threads=None. Every table runs in a fresh
   process (the Rust filter's speed depends on the CPU state of the thread running it).
3. Real images (scikit-image, if installed): camera, astronaut (green), coins, moon in [0, 1]
   plus Gaussian noise σ = 0.1 (seed 0); PSNR and wall time (one call) of ``kf.denoise`` and
   common denoisers (BM3D if the ``bm3d`` package is installed).

Run: ``python benches/bench_row_filters.py [--quick] [--sections loss speed images] [--rhos ...]
[--ratios ...]``; the Markdown report is printed, and a full run (every section, the default
grid) writes the benchmark page ``docs/benchmarks/row_filters.md`` (other runs:
``bench_out/row_filters.md``). The high-SNR table of that page: ``--sections loss --rhos 0.8
0.9 0.95 0.99 --ratios 100 1000 10000``.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import multiprocessing
import os
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, replace

import numpy as np
from bench_page import write_page

import kalmanfield as kf
from kalmanfield.reference.rowfilter import row_filters as ref

ORDERS = ((1, 1), (2, 2), (3, 3), (4, 4), (1, 2), (2, 1))
RHOS = (0.5, 0.8, 0.9, 0.95)
RATIOS = (0.1, 1.0, 10.0)
LOSS_TARGET, GAP_TARGET = 3.0, 5.0
SPEED_RHO = 0.9
EXACT_CHUNK = 512
NOISE_SIGMA = 0.1


@dataclass(frozen=True)
class Config:
    """What to run: grid sizes, cases and repetition counts."""

    loss_size: int
    orders: tuple[tuple[int, int], ...]
    rhos: tuple[float, ...]
    ratios: tuple[float, ...]
    speed_size: int
    repeats: int
    vector_width: int
    sweep_widths: tuple[int, ...]
    setup_widths: tuple[int, ...]
    stack_size: int
    images: tuple[str, ...]
    bm3d: bool
    processes: int


def make_config(quick: bool) -> Config:
    """The full run or the ``--quick`` one."""
    if quick:
        return Config(
            loss_size=32,
            orders=((1, 1), (2, 2), (4, 4)),
            rhos=(0.9, 0.95),
            ratios=RATIOS,
            speed_size=1024,
            repeats=1,
            vector_width=512,
            sweep_widths=(128, 256, 512),
            setup_widths=(1024,),
            stack_size=256,
            images=("camera", "coins"),
            bm3d=False,
            processes=2,
        )
    return Config(
        loss_size=48,
        orders=ORDERS,
        rhos=RHOS,
        ratios=RATIOS,
        speed_size=2048,
        repeats=3,
        vector_width=1024,
        sweep_widths=(128, 256, 512, 1024),
        setup_widths=(1024, 2048, 4096),
        stack_size=512,
        images=("camera", "astronaut", "coins", "moon"),
        bm3d=True,
        processes=3,
    )


def best_of(fn: Callable[[], object], repeats: int) -> float:
    """Smallest wall time of `repeats` calls of `fn`, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def once(fn: Callable[[], object]) -> tuple[float, object]:
    """(wall time in seconds, result) of one call."""
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def model_of(order: tuple[int, int], rho: float) -> kf.ARFieldModel:
    """ARFieldModel(rho=[ρ, ρ], order=order, sigma=1)."""
    return kf.ARFieldModel(rho=[rho, rho], order=list(order), sigma=1.0)


# ----------------------------------------------------------------------------------------------
# 1. loss table


def eigen_images(order: tuple[int, int], rho: float, size: int):
    """(U_y, U_x, λ): Cov(x) = Σ_ab λ_ab v_ab v_abᵀ with orthonormal eigen-images
    v_ab = U_y[:, a] ⊗ U_x[:, b] and λ_ab = λ_y,a λ_x,b (σ_x = 1), λ flattened over (a, b)."""
    ly, uy = np.linalg.eigh(ref.axis_covariance(rho, order[0], size))
    lx, ux = np.linalg.eigh(ref.axis_covariance(rho, order[1], size))
    return uy, ux, np.outer(np.clip(ly, 0, None), np.clip(lx, 0, None)).ravel()


def exact_mse(filters: list, order: tuple[int, int], rho: float, noise_var: float, size: int):
    """Exact mean MSE of each (linear, zero-mean) filter E on a size² grid:
    MSE = Σ_ab [λ_ab ‖E v_ab − v_ab‖² + σ_θ² ‖E v_ab‖²] / size², because Cov(x) = Σ λ v vᵀ and
    the white noise covariance σ_θ² I = σ_θ² Σ v vᵀ share the eigen-images v_ab. Same value as
    ``linear_estimator_mse`` (checked in every run) with H·W filtered images instead of 2·H·W."""
    uy, ux, lam = eigen_images(order, rho, size)
    total = np.zeros(len(filters))
    for lo in range(0, size * size, EXACT_CHUNK):
        a, b = np.divmod(np.arange(lo, min(lo + EXACT_CHUNK, size * size)), size)
        v = uy.T[a][:, :, None] * ux.T[b][:, None, :]  # (B, H, W)
        weight = lam[lo : lo + len(a), None, None]
        for i, filt in enumerate(filters):
            ev = filt.filter(v)
            total[i] += np.sum(weight * (ev - v) ** 2) + noise_var * np.sum(ev**2)
    return list(total / size**2)


def reference_check(size: int) -> str:
    """exact_mse against ``linear_estimator_mse`` (the estimator run on 2·H·W basis images) for
    the (2,2), ρ = 0.9, σ_x²/σ_θ² = 1 scalar filter, causal and smoothed."""
    model, order = model_of((2, 2), 0.9), (2, 2)
    filters = [kf.ScalarRowFilter(model, 1.0, size, smooth=s) for s in (False, True)]

    def estimator(zb: np.ndarray) -> tuple[np.ndarray, ...]:
        stack = np.ascontiguousarray(np.moveaxis(zb, 2, 0))
        return tuple(np.moveaxis(f.filter(stack), 0, 2) for f in filters)

    maps = ref.linear_estimator_mse(estimator, [0.9, 0.9], list(order), 1.0, 1.0, (size, size))
    ours = exact_mse(filters, order, 0.9, 1.0, size)
    diff = max(abs(m.mean() / o - 1) for m, o in zip(maps, ours))
    return (
        f"Cross-check: for (2,2), ρ = 0.9, σ_x²/σ_θ² = 1 the eigen-image MSEs and "
        f"`linear_estimator_mse` agree to a relative {diff:.1e} (causal and smoothed)."
    )


def loss_case(order: tuple[int, int], rho: float, ratio: float, size: int) -> dict:
    """Every MSE of one case of the loss table."""
    model, noise_var = model_of(order, rho), 1.0 / ratio
    filters = [
        kf.ScalarRowFilter(model, noise_var, size),
        kf.ScalarRowFilter(model, noise_var, size, smooth=True),
    ]
    if order == (1, 1):
        filters.append(kf.ScalarRowFilter(model, noise_var, size, ar_order=1))
    mses = exact_mse(filters, order, rho, noise_var, size)
    optimal_map = kf.VectorRowFilter(model, noise_var, size).error_variance(size)
    optimal = float(optimal_map.mean())
    scalar_map = filters[0].error_variance(size)
    bound = kf.wiener_bound(model, noise_var, (size, size))
    return {
        "map_gap": 100 * float(np.max(np.abs(scalar_map / optimal_map - 1))),
        "map_bias": 100 * (mses[0] / float(scalar_map.mean()) - 1),
        "case": (order, rho, ratio),
        "optimal": optimal,
        "causal": mses[0],
        "loss": 100 * (mses[0] / optimal - 1),
        "bound": bound,
        "smooth": mses[1],
        "gap": 100 * (mses[1] / bound - 1),
        "literal": mses[2] if len(mses) > 2 else None,
        "literal_loss": 100 * (mses[2] / optimal - 1) if len(mses) > 2 else None,
    }


def loss_row(r: dict) -> str:
    """One Markdown row of the loss table."""
    (ny, nx), rho, ratio = r["case"]
    literal = "— | —"
    if r["literal"] is not None:
        literal = f"{r['literal']:.5g} | {r['literal_loss']:+.2f}"
    return (
        f"| ({ny},{nx}) | {rho} | {ratio:g} | {r['optimal']:.5g} | {r['causal']:.5g} | "
        f"{r['loss']:+.2f} | {r['bound']:.5g} | {r['smooth']:.5g} | {r['gap']:+.2f} | "
        f"{literal} |"
    )


def worst(results: list[dict], key: str, target: float | None) -> str:
    """'max key = x % at (n), ρ, ratio' with the verdict against the target."""
    rows = [r for r in results if r[key] is not None]
    top = max(rows, key=lambda r: r[key])
    (ny, nx), rho, ratio = top["case"]
    text = f"{top[key]:+.2f} % at ({ny},{nx}), ρ = {rho}, σ_x²/σ_θ² = {ratio:g}"
    if target is None:
        return text
    over = sum(r[key] > target for r in rows)
    verdict = "within target" if over == 0 else f"**{over} case(s) above target**"
    return f"{text} (target ≤ {target:g} %: {verdict})"


def loss_summary(results: list[dict]) -> list[str]:
    """The worst cases of the loss table."""
    return [
        f"- max causal loss (scalar vs optimal vector filter): "
        f"{worst(results, 'loss', LOSS_TARGET)}",
        f"- max smoothed gap (scalar smoothed vs Wiener bound): "
        f"{worst(results, 'gap', GAP_TARGET)}",
        f"- max loss of the source's literal scheme (§2.3, (1,1) only): "
        f"{worst(results, 'literal_loss', None)}",
        f"- `ScalarRowFilter.error_variance` (causal) against the optimal filter's map, "
        f"pixel by pixel: largest |ratio − 1| {max(r['map_gap'] for r in results):.2f} %; "
        f"the filter's exact MSE against the map's mean: "
        f"{min(r['map_bias'] for r in results):+.2f} % … "
        f"{max(r['map_bias'] for r in results):+.2f} %",
    ]


def loss_section(cfg: Config) -> str:
    """Section 1: the exact loss table and its summary."""
    start, size = time.perf_counter(), cfg.loss_size
    cases = [(o, r, q) for o in cfg.orders for r in cfg.rhos for q in cfg.ratios]
    results = [loss_case(*case, size) for case in cases]
    check = reference_check(size)
    elapsed = time.perf_counter() - start
    header = (
        "| (n_y,n_x) | ρ | σ_x²/σ_θ² | optimal causal | scalar causal | loss % | Wiener bound "
        "| scalar smoothed | gap % | §2.3 literal (m=1) causal | literal loss % |"
    )
    return "\n".join(
        [
            f"### 1. Loss table: exact mean MSE on {size}×{size}, σ_x² = 1, ρ_y = ρ_x",
            "",
            header,
            "|---|---|---|" + "---:|" * 8,
            *[loss_row(r) for r in results],
            "",
            *loss_summary(results),
            "",
            "Exact MSEs, no sampling: optimal = `VectorRowFilter.error_variance(H).mean()`; "
            "scalar = `ScalarRowFilter` (default m: 8 for n_y = 1, max(n_x, 2) otherwise) run on "
            "the H·W eigen-images v_ab "
            "of Cov(x), MSE = Σ [λ_ab ‖E v_ab − v_ab‖² + σ_θ² ‖E v_ab‖²] / (H·W) (the white "
            "noise shares that orthonormal basis); bound = `wiener_bound`. Literal = "
            f"`ar_order=1`. {len(results)} cases in {elapsed:.0f} s (default threads).",
            check,
        ]
    )


# ----------------------------------------------------------------------------------------------
# 2. speed


def noisy_field(order: tuple[int, int], shape: tuple[int, ...]) -> np.ndarray:
    """A field of `order`, ρ = SPEED_RHO, plus unit white noise: shape (H, W) or (F, H, W)."""
    rng = np.random.default_rng(1)
    return rng.standard_normal(shape) + model_of(order, SPEED_RHO).sample(shape[-2:], seed=1)


def timed_filter(filt, z: np.ndarray, repeats: int) -> tuple[float, float]:
    """(first call incl. the plan build, best of `repeats` warm calls), seconds."""
    first, _ = once(lambda: filt.filter(z))
    return first, best_of(lambda: filt.filter(z), repeats)


def scalar_speed(cfg: Config) -> list[str]:
    """ScalarRowFilter on speed_size², causal and smoothed, one thread."""
    size = cfg.speed_size
    lines = [
        f"#### ScalarRowFilter, {size}² float64, 1 thread",
        "",
        "| model | pass | first call incl. plan (ms) | best (ms) | Mpixel/s |",
        "|---|---|---:|---:|---:|",
    ]
    for order in ((1, 1), (2, 2), (3, 3), (4, 4)):
        z = noisy_field(order, (size, size))
        for smooth in (False, True):
            model = model_of(order, SPEED_RHO)
            filt = kf.ScalarRowFilter(model, 1.0, size, smooth=smooth, threads=1)
            first, best = timed_filter(filt, z, cfg.repeats)
            lines.append(
                f"| {order} | {'smoothed' if smooth else 'causal'} | {1e3 * first:.0f} | "
                f"{1e3 * best:.1f} | {size * size / best / 1e6:.1f} |"
            )
    return lines


def every_order_speed(cfg: Config) -> list[str]:
    """ScalarRowFilter for every multiplicity (n_y, n_x) ≤ (4, 4): Mpixel/s causal / smoothed
    on speed_size², one thread, best of `repeats` warm calls (plan cached)."""
    size = cfg.speed_size
    lines = [
        f"#### ScalarRowFilter, every multiplicity, {size}² float64, 1 thread "
        "(Mpixel/s, causal / smoothed)",
        "",
        "| n_y \\ n_x | 1 | 2 | 3 | 4 |",
        "|---|---:|---:|---:|---:|",
    ]
    for n_y in (1, 2, 3, 4):
        cells = []
        for n_x in (1, 2, 3, 4):
            order = (n_y, n_x)
            z = noisy_field(order, (size, size))
            rates = []
            for smooth in (False, True):
                model = model_of(order, SPEED_RHO)
                filt = kf.ScalarRowFilter(model, 1.0, size, smooth=smooth, threads=1)
                _, best = timed_filter(filt, z, cfg.repeats)
                rates.append(f"{size * size / best / 1e6:.0f}")
            cells.append(" / ".join(rates))
        lines.append(f"| {n_y} | " + " | ".join(cells) + " |")
    return lines


def setup_row(order: tuple[int, int], width: int) -> str:
    """One row of the set-up table: "ends" against "exact" at one width."""
    model, z = model_of(order, SPEED_RHO), noisy_field(order, (64, width))
    times, outputs, spans = [], [], []
    for modes in ("ends", "exact"):
        start = time.perf_counter()
        filt = kf.ScalarRowFilter(model, 1.0, width, threads=1, modes=modes)
        made = time.perf_counter()
        outputs.append(filt.filter(z))
        times.append((made - start, time.perf_counter() - made))
        spans.append(filt.ends_span)
    (ends_make, ends_plan), (exact_make, exact_plan) = times
    ratio = (exact_make + exact_plan) / (ends_make + ends_plan)
    return (
        f"| {order} | {width} | {spans[0]} | {ends_make:.2f} + {ends_plan:.2f} | "
        f"{exact_make:.2f} + {exact_plan:.2f} | {ratio:.0f}× | "
        f"{np.abs(outputs[0] - outputs[1]).max():.0e} |"
    )


def setup_speed(cfg: Config) -> list[str]:
    """ScalarRowFilter construction + plan, "ends" against "exact", per width."""
    lines = [
        "#### ScalarRowFilter set-up: spliced ends against the whole row's eigenbasis, 1 thread",
        "",
        "| model | W | W' | ends: construct + plan (s) | exact: construct + plan (s) "
        "| × faster | max output difference |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for order in ((1, 1), (2, 2), (3, 3)):
        lines += [isolated(setup_row, order, width) for width in cfg.setup_widths]
    lines += [
        "",
        "The plan is that of a 64-row image (the row models until they settle); the images "
        "are the unit-variance field plus unit white noise.",
    ]
    return lines


def reference_row(order: tuple[int, int], size: int, repeats: int) -> str:
    """One row of the reference-vs-Rust table."""
    z, args = noisy_field(order, (size, size)), ([SPEED_RHO] * 2, order, 1.0, 1.0)
    plan_t, plan = once(lambda: ref.scalar_filter_plan(*args, size, size))
    np_t = best_of(lambda: ref.scalar_row_filter(z, *args, plan=plan), repeats)
    filt = kf.ScalarRowFilter(model_of(order, SPEED_RHO), 1.0, size, threads=1)
    first, best = timed_filter(filt, z, repeats)
    return (
        f"| {order} | {1e3 * plan_t:.0f} | {1e3 * np_t:.1f} | {1e3 * first:.1f} | "
        f"{1e3 * best:.2f} | {np_t / best:.0f} | {(plan_t + np_t) / first:.0f} |"
    )


def reference_speed(repeats: int, size: int = 256) -> list[str]:
    """NumPy reference scalar_row_filter vs the Rust one, causal, size²."""
    return [
        f"#### NumPy reference vs Rust, `scalar_row_filter` causal, {size}², 1 thread",
        "",
        "| model | NumPy plan (ms) | NumPy filter (ms) | Rust first call incl. plan (ms) "
        "| Rust filter (ms) | × faster (filter) | × faster (plan + filter) |",
        "|---|---:|---:|---:|---:|---:|---:|",
        *[reference_row(order, size, repeats) for order in ((1, 1), (2, 2), (3, 3))],
        "",
        "NumPy: `reference.row_filters.scalar_filter_plan` once, then `scalar_row_filter(..., "
        "plan=plan)`; Rust: the first call builds the same plan, the later ones reuse it.",
    ]


def vector_speed(cfg: Config) -> list[str]:
    """VectorRowFilter construction and filter time at width vector_width, (2,2)."""
    width, model = cfg.vector_width, model_of((2, 2), SPEED_RHO)
    build = best_of(lambda: kf.VectorRowFilter(model, 1.0, width, threads=1), cfg.repeats)
    z = noisy_field((2, 2), (width, width))
    rows = []
    for smooth in (False, True):
        filt = kf.VectorRowFilter(model, 1.0, width, smooth=smooth, threads=1)
        first, best = timed_filter(filt, z, cfg.repeats)
        rows.append(
            f"| filter {width}², {'smoothed' if smooth else 'causal'} | {1e3 * best:.0f} "
            f"(first call {1e3 * first:.0f}) | {width * width / best / 1e6:.2f} |"
        )
    return [
        f"#### VectorRowFilter (2,2), width {width}, 1 thread",
        "",
        "| what | ms | Mpixel/s |",
        "|---|---:|---:|",
        f"| construction (eigendecomposition of the {width}×{width} row covariance) | "
        f"{1e3 * build:.0f} | — |",
        *rows,
    ]


def sweep_row(order: tuple[int, int], width: int, repeats: int) -> str:
    """One row of the width sweep: warm causal filter times, the scalar filter first."""
    model, z = model_of(order, SPEED_RHO), noisy_field(order, (width, width))
    sca = timed_filter(kf.ScalarRowFilter(model, 1.0, width, threads=1), z, repeats)[1]
    vec = timed_filter(kf.VectorRowFilter(model, 1.0, width, threads=1), z, repeats)[1]
    return f"| {order} | {width} | {1e3 * vec:.1f} | {1e3 * sca:.2f} | {vec / sca:.1f} |"


def sweep_speed(cfg: Config) -> list[str]:
    """Optimal (vector) / quasi-optimal (scalar) filter time against the width, causal; every
    row in a fresh process."""
    rows = [
        isolated(sweep_row, order, width, cfg.repeats)
        for order in ((1, 1), (2, 2))
        for width in cfg.sweep_widths
    ]
    return [
        "#### Optimal vs quasi-optimal, causal, H = W, 1 thread (construction / plan excluded)",
        "",
        "| model | W | VectorRowFilter (ms) | ScalarRowFilter (ms) | vector / scalar |",
        "|---|---:|---:|---:|---:|",
        *rows,
        "",
        "During the slow episode described under the last table, the filters' constructors at "
        "small widths (W = 48) also left the calling thread slow; the scalar (2,2) time at "
        "W = 128 was then 3–5 ms instead of ~1 ms.",
    ]


def stack_speed(cfg: Config) -> list[str]:
    """8 frames through ScalarRowFilter (2,2) smoothed: 1 thread, an explicit pool of all cores,
    then the default global pool (threads=None) last, as it leaves the calling thread slow."""
    size, model, cores = cfg.stack_size, model_of((2, 2), SPEED_RHO), os.cpu_count()
    z = noisy_field((2, 2), (8, size, size))
    rows = []
    for threads, label in ((1, "1"), (cores, str(cores)), (None, f"None (default, {cores})")):
        filt = kf.ScalarRowFilter(model, 1.0, size, smooth=True, threads=threads)
        best = timed_filter(filt, z, cfg.repeats)[1]
        rows.append((label, best))
    return [
        f"#### Stack of 8 frames {size}², ScalarRowFilter (2,2) smoothed",
        "",
        "| threads | ms | Mpixel/s | speed-up vs 1 thread |",
        "|---|---:|---:|---:|",
        *[
            f"| {label} | {1e3 * t:.0f} | {8 * size * size / t / 1e6:.1f} | {rows[0][1] / t:.2f} |"
            for label, t in rows
        ],
    ]


def calling_thread_pair(size: int, repeats: int) -> tuple[float, float]:
    """(threads=1, threads=None) best warm times of ScalarRowFilter (2,2) causal on one size²
    image, threads=1 first (its plan is built on a throw-away pool thread)."""
    model, z = model_of((2, 2), SPEED_RHO), noisy_field((2, 2), (size, size))
    times = []
    for threads in (1, None):
        filt = kf.ScalarRowFilter(model, 1.0, size, threads=threads)
        times.append(timed_filter(filt, z, repeats)[1])
    return times[0], times[1]


def calling_thread_speed(cfg: Config) -> list[str]:
    """threads=1 against the default threads=None on one image, in several fresh processes."""
    size = min(cfg.speed_size, 1024)
    pairs = [isolated(calling_thread_pair, size, cfg.repeats) for _ in range(cfg.processes)]
    return [
        f"#### Default threads=None vs threads=1, ScalarRowFilter (2,2) causal, {size}², one "
        "image (filtered sequentially either way)",
        "",
        "| fresh process | threads=1 (ms) | threads=None (ms) | None / 1 |",
        "|---|---:|---:|---:|",
        *[
            f"| {i + 1} | {1e3 * one:.1f} | {1e3 * default:.1f} | {default / one:.2f} |"
            for i, (one, default) in enumerate(pairs)
        ],
        "",
        "The two should agree. While this script was being written (same machine, same day) "
        "threads=None was 4–6× slower than threads=1 for n_y = 2 and 3 in every process for "
        "about half an hour (e.g. 926 vs 182 ms at 2048², and the 8-frame stack above 5.5× "
        "slower), then the effect vanished. Outputs were bit-identical, and one `vzeroupper` "
        "instruction executed on the slow thread (a scratch ctypes helper) restored full "
        "speed: a dirty upper AVX register state, left by the plan build (presumably faer's "
        "AVX-512 kernels) on the thread that then runs the filter's non-VEX SSE loops. With "
        "threads=k the plan is built on a throw-away pool thread; pool threads created from "
        "a dirty thread inherit the state. Environment-dependent; rerun if the ratio is ≫ 1.",
    ]


def error_map_row(order: tuple[int, int], width: int, repeats: int) -> str:
    """One row of ``error_map_speed``."""
    model = model_of(order, SPEED_RHO)
    scalar = kf.ScalarRowFilter(model, 1.0, width, threads=1)
    first, _ = once(lambda: scalar.error_variance(width))
    cached = best_of(lambda: scalar.error_variance(width), repeats)
    vector = best_of(
        lambda: kf.VectorRowFilter(model, 1.0, width, threads=1).error_variance(width), repeats
    )
    return (
        f"| {order} | {1e3 * cached:.0f} (first call {1e3 * first:.0f}) | "
        f"{1e3 * vector:.0f} | {vector / cached:.0f}× |"
    )


def error_map_speed(cfg: Config) -> list[str]:
    """Per-pixel error maps at vector_width² (one thread): the O(W) filter's own map
    (selected inversion of its row systems) against the optimal filter's (eigenbasis)."""
    width = cfg.vector_width
    return [
        f"#### Per-pixel error maps, {width}², 1 thread",
        "",
        "| model | `ScalarRowFilter.error_variance` ms | `VectorRowFilter` construction + "
        "`error_variance` ms | ratio |",
        "|---|---:|---:|---:|",
        *(error_map_row(order, width, cfg.repeats) for order in ORDERS[:4]),
    ]


def isolated(fn: Callable, *args: object) -> object:
    """fn(*args) in a fresh interpreter (spawn): no CPU state is left over from earlier
    measurements (see the threads=None table)."""
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        return pool.submit(fn, *args).result()


def speed_section(cfg: Config) -> str:
    """Section 2: every speed table, measured in fresh processes."""
    parts = [
        isolated(scalar_speed, cfg),
        isolated(every_order_speed, cfg),
        isolated(reference_speed, cfg.repeats),
        isolated(reference_speed, cfg.repeats, cfg.speed_size),
        isolated(vector_speed, cfg),
        isolated(error_map_speed, cfg),
        sweep_speed(cfg),
        setup_speed(cfg),
        isolated(stack_speed, cfg),
        isolated(calling_thread_speed, cfg),
    ]
    head = [
        f"### 2. Speed (ρ = {SPEED_RHO} on both axes, σ_θ² = 1, best of {cfg.repeats})",
        "",
        "Every filter is warmed up by one call on the same image size (the per-height plan — "
        "for the scalar filter the row-by-row model fit — is built then and cached); "
        "“first call” includes it. The Rust scalar filter's speed depends on the CPU state "
        "of the thread that runs it (see the last table), so each table — each row of the "
        "width sweep — runs in a fresh process.",
    ]
    return "\n\n".join(["\n".join(head)] + ["\n".join(p) for p in parts])


# ----------------------------------------------------------------------------------------------
# 3. real images


def test_image(name: str) -> np.ndarray:
    """A clean scikit-image test image as float64 in [0, 1] (astronaut: green channel)."""
    from skimage import data, img_as_float

    image = getattr(data, name)()
    return img_as_float(image[..., 1] if image.ndim == 3 else image)


def skimage_wiener(z: np.ndarray) -> np.ndarray:
    """skimage.restoration.wiener with a δ PSF: global Wiener–Hunt (Laplacian-regularised)
    smoothing, x̂ = F⁻¹[Z / (1 + balance·|Λ|²)], balance = 0.1."""
    from skimage.restoration import wiener

    return wiener(z, np.ones((1, 1)), balance=0.1, clip=False)


def bm3d_denoise(z: np.ndarray) -> np.ndarray:
    """bm3d.bm3d(z, σ) (ImportError when the package is absent)."""
    import bm3d

    return bm3d.bm3d(z, NOISE_SIGMA)


def rs_wavelet(z: np.ndarray) -> np.ndarray:
    """skimage's BayesShrink wavelet denoiser (needs PyWavelets)."""
    from skimage.restoration import denoise_wavelet

    return denoise_wavelet(z, rescale_sigma=True)


def nl_means(z: np.ndarray) -> np.ndarray:
    """skimage's fast non-local means, h = 0.8σ, 5×5 patches, distance 6."""
    from skimage.restoration import denoise_nl_means

    s = NOISE_SIGMA
    return denoise_nl_means(z, h=0.8 * s, sigma=s, fast_mode=True, patch_size=5, patch_distance=6)


KF_KEYS = ("kf", "kf_adaptive", "kf_stationary", "kf_noise", "kf_vector")


def denoisers() -> dict[str, tuple[str, Callable[[np.ndarray], np.ndarray]]]:
    """key → (label, z ↦ estimate) of every method of section 3."""
    from scipy.signal import wiener
    from skimage import restoration as rs

    s = NOISE_SIGMA
    return {
        "noisy": ("noisy input", lambda z: z),
        "kf": ("`kf.denoise(z)` (all estimated, the filter chosen by SURE)", kf.denoise),
        "kf_adaptive": (
            '`kf.denoise(z, method="adaptive")`',
            lambda z: kf.denoise(z, method="adaptive"),
        ),
        "kf_stationary": (
            '`kf.denoise(z, method="stationary")` (one stationary model)',
            lambda z: kf.denoise(z, method="stationary"),
        ),
        "kf_noise": ("`kf.denoise(z, noise_var=σ²)`", lambda z: kf.denoise(z, noise_var=s**2)),
        "kf_vector": (
            '`kf.denoise(z, method="vector")`',
            lambda z: kf.denoise(z, method="vector"),
        ),
        "scipy_wiener": ("`scipy.signal.wiener(z, (5, 5))`", lambda z: wiener(z, (5, 5))),
        "sk_wiener": ("`skimage wiener`, δ PSF, balance 0.1 †", skimage_wiener),
        "tv": ("`denoise_tv_chambolle(z, weight=0.1)`", lambda z: rs.denoise_tv_chambolle(z, 0.1)),
        "wavelet": ("`denoise_wavelet(z, rescale_sigma=True)`", rs_wavelet),
        "nlm": ("`denoise_nl_means` (h = 0.8σ, fast, 5/6)", nl_means),
        "bm3d": ("`bm3d.bm3d(z, σ)`", bm3d_denoise),
    }


def run_method(fn: Callable, z: np.ndarray, clean: np.ndarray) -> tuple[str, str]:
    """(PSNR cell, ms cell), 'n/a' cells when an optional package is missing. The time is the
    best of 5 calls (this VM's timings vary), of 1 for methods slower than a second."""
    try:
        secs, est = once(lambda: fn(z))
    except ImportError as err:
        return f"n/a ({err.name})", "—"
    if secs < 1.0:
        secs = min(secs, best_of(lambda: fn(z), 4))
    psnr = 10 * np.log10(1.0 / np.mean((np.asarray(est) - clean) ** 2))
    return f"{psnr:.2f}", f"{1e3 * secs:.1f}" if secs < 0.01 else f"{1e3 * secs:.0f}"


def preload() -> None:
    """Import the optional packages, so that no timing includes an import."""
    for module in ("pywt", "bm3d"):
        try:
            importlib.import_module(module)
        except ImportError:
            pass


def settle_allocator() -> None:
    """Allocate and free one 16 MiB block before timing. glibc then raises its mmap threshold
    (to the freed block's size), so that every method's frame-sized temporaries come from the
    heap; before that, each call maps them afresh and pays a page fault per 4 KiB (measured:
    ``scipy.signal.wiener`` took 4 or 9–18 ms on coins depending on what had run before it
    in the process)."""
    block = np.ones(1 << 21)
    del block


def measure(keys: tuple[str, ...], names: tuple[str, ...]) -> tuple[list, dict]:
    """(image shapes, (key, name) → (PSNR, ms) cells) of the methods `keys` on the noisy test
    images `names`."""
    preload()
    settle_allocator()
    methods, shapes, cells = denoisers(), [], {}
    for name in names:
        clean = test_image(name)
        z = clean + NOISE_SIGMA * np.random.default_rng(0).standard_normal(clean.shape)
        shapes.append(clean.shape)
        for key in keys:
            cells[key, name] = run_method(methods[key][1], z, clean)
    return shapes, cells


def image_table(title: str, names: list[str], rows: list[tuple[str, list[str]]]) -> list[str]:
    """One Markdown table: methods × images."""
    return [
        title,
        "",
        "| method | " + " | ".join(names) + " |",
        "|---|" + "---:|" * len(names),
        *[f"| {label} | " + " | ".join(cells) + " |" for label, cells in rows],
    ]


def measure_all(cfg: Config, keys: list[str]) -> tuple[list[str], dict]:
    """Column names and (key, name) → cells. Fresh processes: one for the other methods, one
    per kalmanfield call (see the threads=None table)."""
    others = tuple(key for key in keys if key not in KF_KEYS)
    shapes, cells = isolated(measure, others, cfg.images)
    for key in KF_KEYS:
        cells.update(isolated(measure, (key,), cfg.images)[1])
    names = [f"{name} {h}×{w}" for name, (h, w) in zip(cfg.images, shapes)]
    return names, cells


def images_section(cfg: Config) -> str:
    """Section 3: PSNR and time of denoisers on noisy test images."""
    if importlib.util.find_spec("skimage") is None:
        return "### 3. Real images\n\nscikit-image is not installed: skipped."
    methods = denoisers()
    keys = [key for key in methods if cfg.bm3d or key != "bm3d"]
    names, cells = measure_all(cfg, keys)
    notes = [
        "",
        "PSNR = 10 log10(1 / MSE) against the clean image, outputs not clipped; time: best of 5 "
        "calls (1 above a second; wall time, default threads; one image, so one core for "
        "kalmanfield); each `kf.denoise` variant runs in its own fresh process. "
        "`kf.denoise` estimates σ_θ² (Haar MAD) and the model from the noisy image unless told.",
        "† With a δ PSF `skimage.restoration.wiener` deconvolves nothing: it is a global "
        "Laplacian-regularised (Tikhonov) smoother, x̂ = F⁻¹[Z / (1 + balance·|Λ|²)], with a "
        "hand-set balance of 0.1 — neither σ nor a signal model enters.",
    ]
    if not cfg.bm3d:
        notes.append("BM3D skipped in --quick (about 15 s per 512² image).")
    psnr_rows = [(methods[k][0], [cells[k, n][0] for n in cfg.images]) for k in keys]
    time_rows = [(methods[k][0], [cells[k, n][1] for n in cfg.images]) for k in keys[1:]]
    title = f"### 3. Real images + Gaussian noise σ = {NOISE_SIGMA} (seed 0): PSNR (dB)"
    return "\n".join(
        image_table(title, names, psnr_rows)
        + [""]
        + image_table("#### Time (ms, one call)", names, time_rows)
        + notes
    )


# ----------------------------------------------------------------------------------------------


def main() -> None:
    """Parse the CLI, run, print and save the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--quick", action="store_true", help="32² loss grid, fewer cases, 1 repeat, no BM3D"
    )
    parser.add_argument(
        "--sections",
        nargs="+",
        choices=tuple(SECTIONS),
        default=list(SECTIONS),
        help="the sections to run (default: all three)",
    )
    parser.add_argument(
        "--rhos", nargs="+", type=float, help="ρ of the loss table (default 0.5 0.8 0.9 0.95)"
    )
    parser.add_argument(
        "--ratios",
        nargs="+",
        type=float,
        help="σ_x²/σ_θ² of the loss table (default 0.1 1 10, the issue's grid; e.g. 100 1000 "
        "10000 for the high-SNR table of the benchmark page)",
    )
    args = parser.parse_args()
    cfg = make_config(args.quick)
    cfg = replace(cfg, rhos=tuple(args.rhos or cfg.rhos), ratios=tuple(args.ratios or cfg.ratios))
    start = time.perf_counter()
    sections = [SECTIONS[name](cfg) for name in args.sections]
    report = "\n\n".join(sections)
    report += f"\n\nTotal run time: {time.perf_counter() - start:.0f} s.\n"
    print(report)
    full_run = not (args.quick or args.rhos or args.ratios) and args.sections == list(SECTIONS)
    write_page("row_filters", "Benchmark: row filters and denoising", report, full_run=full_run)


SECTIONS = {"loss": loss_section, "speed": speed_section, "images": images_section}


if __name__ == "__main__":
    main()
