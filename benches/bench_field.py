"""Benchmark of the random-field generator ``kf.ARFieldModel.sample`` against alternatives.

Measures, in one run on one machine (best of a few repetitions, ``time.perf_counter``):

1. the NumPy white-noise floor ``default_rng(1).standard_normal(shape, dtype)``;
2. ``ARFieldModel([0.9, 0.9], [n, n]).sample`` for n = 2 and 4, 2048² and 4096² grids,
   float64 / float32, one thread and all cores;
3. a ``scipy.signal.lfilter`` cascade of the AR polynomial (1 - ρ z⁻¹)^n along axis 1 then
   axis 0 with zero initial conditions (not stationary at the edges: a speed baseline only);
4. an FFT circulant-embedding generator of the same separable covariance on a (2H, 2W) torus
   (eigenvalues precomputed, the time is per sample);
5. GSTools ``SRF(Exponential(dim=2, len_scale=10))`` on a 256² structured grid (if installed);
6. the peak memory of ``sample`` above its output, measured in a fresh subprocess;
7. frames/s of the 1024² stream of the (1, 2, 2) space–time model on one thread.

Throughput is in Mpixel/s; "× floor" is the best time divided by the best time of the NumPy
floor of the same grid and dtype, measured in the same run.

Run: ``python benches/bench_field.py [--quick]`` (``--quick``: 2048² only, fewer repeats).
The Markdown report is printed and written to the benchmark page ``docs/benchmarks/field.md``
(``--quick``: to ``bench_out/field.md``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from math import comb

import numpy as np
from bench_page import write_page
from scipy import signal

import kalmanfield as kf

RHO = 0.9
ORDERS = (2, 4)
DTYPES: tuple[type[np.floating], ...] = (np.float64, np.float32)


@dataclass(frozen=True)
class Config:
    """What to run: grid sizes and repetition counts."""

    sizes: tuple[int, ...]
    repeats: dict[int, int]
    fft_sizes: tuple[int, ...]
    stream_frames: int
    stream_blocks: int
    gstools_repeats: int
    memory_size: int


@dataclass(frozen=True)
class Row:
    """One timed result of the main table."""

    method: str
    model: str
    size: int
    dtype: str
    threads: str
    seconds: float
    floor: float

    def cells(self) -> list[str]:
        """Markdown cells: method, model, grid, dtype, threads, ms, Mpixel/s, × floor."""
        mpix = self.size * self.size / self.seconds / 1e6
        return [
            self.method,
            self.model,
            f"{self.size}²",
            self.dtype,
            self.threads,
            f"{self.seconds * 1e3:.1f}",
            f"{mpix:.1f}" if mpix >= 1 else f"{mpix:.3f}",
            f"{self.seconds / self.floor:.2f}",
        ]


def make_config(quick: bool) -> Config:
    """The full run or the ``--quick`` one."""
    if quick:
        return Config((2048,), {2048: 3}, (2048,), 15, 1, 1, 2048)
    return Config((2048, 4096), {2048: 5, 4096: 3}, (2048, 4096), 30, 3, 2, 4096)


def best_of(fn: Callable[[], object], repeats: int) -> float:
    """Smallest wall time of `repeats` calls of `fn`, in seconds."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def threads_label(threads: int | None) -> str:
    """'1' or 'all (N)'."""
    return str(threads) if threads is not None else f"all ({os.cpu_count()})"


def numpy_floor(size: int, dtype: type[np.floating], repeats: int) -> float:
    """Best time of drawing a size² standard normal array with NumPy."""

    def draw() -> np.ndarray:
        return np.random.default_rng(1).standard_normal((size, size), dtype=dtype)

    return best_of(draw, repeats)


def bench_kalmanfield(size: int, dtype: type[np.floating], repeats: int, floor: float) -> list[Row]:
    """ARFieldModel.sample for every order and thread setting."""
    rows = []
    for order in ORDERS:
        model = kf.ARFieldModel([RHO, RHO], [order, order])
        for threads in (1, None):

            def run(m: kf.ARFieldModel = model, t: int | None = threads) -> np.ndarray:
                return m.sample((size, size), seed=1, dtype=dtype, threads=t)

            secs = best_of(run, repeats)
            rows.append(
                Row(
                    "kalmanfield sample",
                    f"({order},{order})",
                    size,
                    np.dtype(dtype).name,
                    threads_label(threads),
                    secs,
                    floor,
                )
            )
    return rows


def ar_polynomial(order: int) -> np.ndarray:
    """Coefficients of (1 - ρ z⁻¹)^order in powers of z⁻¹."""
    return np.array([comb(order, j) * (-RHO) ** j for j in range(order + 1)])


def lfilter_field(size: int, order: int, dtype: type[np.floating]) -> np.ndarray:
    """White noise filtered by 1/(1 - ρ z⁻¹)^order along axis 1 then axis 0 (zero start)."""
    noise = np.random.default_rng(1).standard_normal((size, size), dtype=dtype)
    a = ar_polynomial(order).astype(dtype)
    b = np.ones(1, dtype=dtype)
    return signal.lfilter(b, a, signal.lfilter(b, a, noise, axis=1), axis=0)


def bench_lfilter(size: int, dtype: type[np.floating], repeats: int, floor: float) -> list[Row]:
    """The scipy.signal.lfilter cascade (noise drawing included) for every order."""
    rows = []
    for order in ORDERS:
        secs = best_of(lambda o=order: lfilter_field(size, o, dtype), repeats)
        rows.append(
            Row(
                "scipy lfilter cascade †",
                f"({order},{order})",
                size,
                np.dtype(dtype).name,
                "1",
                secs,
                floor,
            )
        )
    return rows


def torus_lags(n: int) -> np.ndarray:
    """Lags min(k, n - k), k = 0..n-1, of a periodic axis of length n."""
    k = np.arange(n)
    return np.minimum(k, n - k)


def circulant_sqrt_eigenvalues(model: kf.ARFieldModel, size: int) -> np.ndarray:
    """sqrt(λ / M) of the covariance embedded on the (2·size)² torus, M = (2·size)².

    The covariance is separable, so the torus covariance σ² R1(k) R2(l) is built as the
    outer product of model.correlation on the lags (k, 0) and (0, l), divided by σ².
    """
    lags = torus_lags(2 * size)
    zeros = np.zeros_like(lags)
    c0 = model.correlation(np.stack([lags, zeros], axis=-1))
    c1 = model.correlation(np.stack([zeros, lags], axis=-1))
    eig = np.fft.fft2(np.outer(c0, c1) / model.sigma**2).real
    np.clip(eig, 0.0, None, out=eig)
    return np.sqrt(eig / eig.size)


def circulant_sample(sqrt_eig: np.ndarray, size: int, rng: np.random.Generator) -> np.ndarray:
    """Real part of FFT(sqrt(λ/M) · (ξ1 + iξ2)) cut to the size² corner."""
    z = np.empty(sqrt_eig.shape, dtype=np.complex128)
    z.real = rng.standard_normal(sqrt_eig.shape)
    z.imag = rng.standard_normal(sqrt_eig.shape)
    z *= sqrt_eig
    return np.fft.fft2(z)[:size, :size].real.copy()


def bench_fft(size: int, orders: tuple[int, ...], repeats: int, floor: float) -> list[Row]:
    """Circulant-embedding time per float64 sample, eigenvalues precomputed."""
    rows = []
    for order in orders:
        model = kf.ARFieldModel([RHO, RHO], [order, order])
        sqrt_eig = circulant_sqrt_eigenvalues(model, size)
        rng = np.random.default_rng(1)
        secs = best_of(lambda s=sqrt_eig, g=rng: circulant_sample(s, size, g), repeats)
        rows.append(
            Row(
                "FFT circulant embedding ‡", f"({order},{order})", size, "float64", "1", secs, floor
            )
        )
        del sqrt_eig
    return rows


def bench_gstools(repeats: int) -> Row | str:
    """GSTools SRF on a 256² structured grid, or a note saying why it was skipped."""
    try:
        import gstools
    except ImportError:
        return "GSTools is not installed: skipped (pip install gstools)."
    size = 256
    axis = np.arange(size, dtype=np.float64)
    srf = gstools.SRF(gstools.Exponential(dim=2, var=1, len_scale=10), seed=1)
    secs = best_of(lambda: srf.structured([axis, axis]), repeats)
    floor = numpy_floor(size, np.float64, 5)
    return Row(
        f"GSTools {gstools.__version__} SRF §", "Exp(ℓ=10)", size, "float64", "default", secs, floor
    )


MEMORY_CODE = """
import json, resource, sys
import numpy as np
import kalmanfield as kf
size, threads = int(sys.argv[1]), json.loads(sys.argv[2])
model = kf.ARFieldModel([0.9, 0.9], [2, 2])
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
x = model.sample((size, size), seed=1, dtype=np.float64, threads=threads)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(json.dumps([before, after, x.nbytes]))
"""

# Linux carries the RSS high-water mark of the forking process over exec into ru_maxrss, so a
# child forked from this (large) process would report our peak. A bare Python launcher runs
# the measurement in a grandchild, whose inherited mark is only the launcher's few MiB.
LAUNCHER_CODE = (
    "import subprocess, sys; "
    "sys.exit(subprocess.run([sys.executable, '-c', *sys.argv[1:]]).returncode)"
)


def measure_memory(size: int, threads: int | None) -> tuple[float, float]:
    """Peak RSS increase of one sample minus its output, in MiB and as a fraction of it."""
    out = subprocess.run(
        [sys.executable, "-c", LAUNCHER_CODE, MEMORY_CODE, str(size), json.dumps(threads)],
        capture_output=True,
        text=True,
        check=True,
    )
    before_kib, after_kib, nbytes = json.loads(out.stdout)
    extra = (after_kib - before_kib) * 1024 - nbytes
    return extra / 2**20, extra / nbytes


def memory_section(size: int) -> list[str]:
    """Markdown table of the extra peak memory of sample, one row per thread setting."""
    lines = [
        f"### Peak memory of `sample`, model (2,2), {size}² float64 "
        f"(output {size * size * 8 / 2**20:.0f} MiB)",
        "",
        "| Threads | Peak increase − output (MiB) | Fraction of output |",
        "|---|---:|---:|",
    ]
    for threads in (1, None):
        mib, frac = measure_memory(size, threads)
        lines.append(f"| {threads_label(threads)} | {mib:.1f} | {frac:.3f} |")
    lines += [
        "",
        "`ru_maxrss` before/after one sample in a fresh subprocess (after importing "
        "numpy and kalmanfield); 0 means the peak is the output array itself.",
    ]
    return lines


def stream_section(frames: int, blocks: int, floor: float) -> list[str]:
    """Frames/s of the 1024² stream of the (1,2,2) model, one thread, 2 warm-up frames."""
    size = 1024
    model = kf.ARFieldModel([RHO, RHO, RHO], [1, 2, 2])
    stream = iter(model.stream((size, size), seed=1, threads=1))
    for _ in range(2):
        next(stream)
    secs = best_of(lambda: [next(stream) for _ in range(frames)], blocks) / frames
    return [
        f"### Streaming, model (1,2,2) ρ = {RHO}, {size}² float64 frames, threads = 1",
        "",
        f"- {1 / secs:.1f} frames/s ({secs * 1e3:.2f} ms/frame, "
        f"{size * size / secs / 1e6:.1f} Mpixel/s, {secs / floor:.2f} × the NumPy floor of "
        f"one {size}² frame); best of {blocks} block(s) of {frames} frames after 2 warm-up "
        "frames.",
    ]


def markdown_table(rows: list[Row]) -> list[str]:
    """The main results as a Markdown table."""
    header = ["Method", "Model", "Grid", "dtype", "Threads", "Best (ms)", "Mpixel/s", "× floor"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * 3 + "---|---|" + "---:|" * 3]
    lines += ["| " + " | ".join(row.cells()) + " |" for row in rows]
    return lines


def main_rows(cfg: Config) -> tuple[list[Row], dict[tuple[int, str], float]]:
    """Floor, kalmanfield, lfilter and FFT rows, and the floors by (size, dtype name)."""
    rows: list[Row] = []
    floors: dict[tuple[int, str], float] = {}
    for size in cfg.sizes:
        reps = cfg.repeats[size]
        for dtype in DTYPES:
            name = np.dtype(dtype).name
            floor = floors[size, name] = numpy_floor(size, dtype, reps)
            rows.append(
                Row("NumPy standard_normal (floor)", "white", size, name, "1", floor, floor)
            )
            rows += bench_kalmanfield(size, dtype, reps, floor)
            rows += bench_lfilter(size, dtype, reps, floor)
        if size in cfg.fft_sizes:
            orders = ORDERS if size <= 2048 else ORDERS[:1]
            rows += bench_fft(size, orders, max(2, reps - 2), floors[size, "float64"])
    return rows, floors


def notes(cfg: Config, gstools_note: str | None) -> list[str]:
    """Footnotes of the main table."""
    reps = ", ".join(f"{n} ({size}²)" for size, n in cfg.repeats.items())
    lines = [
        f"ρ = {RHO} on both axes, σ = 1. Best of {reps} repetitions (FFT: fewer; GSTools: "
        f"{cfg.gstools_repeats}). “× floor” = best time / best time of the NumPy floor of the "
        "same grid and dtype (< 1: faster than NumPy drawing the white noise alone).",
        "",
        "† Speed baseline only: zero initial conditions, so the field is not stationary at "
        "the edges (kalmanfield's `sample` is). Noise drawing included.",
        "‡ Eigenvalues of the (2H, 2W) torus embedding precomputed (not timed); time per "
        "sample = complex white noise + one `np.fft.fft2` (single-threaded) + H×W corner. "
        "Cost does not depend on the model"
        + (
            "; 4096² (8192² complex torus) run for (2,2) only."
            if max(cfg.fft_sizes) > 2048
            else "; 2048² only (--quick)."
        ),
        f"§ {gstools_note}"
        if gstools_note
        else "§ Isotropic exponential covariance by the randomization method (approximate; "
        "different model), timed `srf.structured` call, × floor against the 256² NumPy floor.",
    ]
    return lines


def run(cfg: Config) -> str:
    """Every benchmark, as one Markdown report."""
    rows, _ = main_rows(cfg)
    gs = bench_gstools(cfg.gstools_repeats)
    gstools_note = gs if isinstance(gs, str) else None
    if isinstance(gs, Row):
        rows.append(gs)
    stream_floor = numpy_floor(1024, np.float64, 5)
    lines = ["## Generation speed", ""]
    lines += markdown_table(rows) + [""] + notes(cfg, gstools_note) + [""]
    lines += memory_section(cfg.memory_size) + [""]
    lines += stream_section(cfg.stream_frames, cfg.stream_blocks, stream_floor)
    return "\n".join(lines) + "\n"


def main() -> None:
    """Parse the CLI, run, print and save the report."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2048² only, fewer repeats")
    args = parser.parse_args()
    start = time.perf_counter()
    report = run(make_config(args.quick))
    print(report)
    write_page("field", "Benchmark: field generation", report, full_run=not args.quick)
    print(f"(total {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
