"""Change-detection study (method page *Fuzzy filter*, §4.4; [K95 8–10]): mean detection
delay against false alarms per 1,000 samples for the fuzzy, χ² and CUSUM detectors of
``kalmanfield.ChangeDetector``, and ``ruptures`` (offline, sees the whole series) as the
reference, when installed.

Scenarios (2 × 2): a jump in position (size ``POSITION_JUMP`` R) or in velocity
(``VELOCITY_JUMP`` R per sample) at a uniform random time in [100, 300) of a 400-sample
series, random sign; Gaussian or Student-t (3 d.o.f., scaled to the same variance)
measurement noise. Trajectories follow the model with process noise Q = 0.05 R,
Q' = 0.002 R; every filter has the true spreads (P = 2R, P' = 0.5R).

Per method and confidence: false alarms = alarms before the jump per 1,000 pre-jump samples;
delay = first alarm at or after the jump minus the jump time (missed beyond ``HORIZON``
samples; the detection rate is reported). ruptures: binary segmentation with the piecewise-linear
cost on (z, t) and a penalty sweep; its "delay" is |estimated − true| of the nearest breakpoint and
its false alarms the other breakpoints.

Winner: at each false-alarm level of ``LEVELS`` (per 1,000 samples), the online method with the
smallest delay (curves interpolated in log false-alarm rate, detection rate ≥ 90 %).

Run: ``python benches/study_change_detection.py [--quick] [--series 2000]``; the report is
printed and written to the benchmark page ``docs/benchmarks/change_detection.md``, the plot to
``docs/images/trajectory_change_detection.png`` (``--quick``: 150 series, no plot; a quick run
or other options write the page to ``bench_out/`` instead).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_page import ROOT, SCRATCH, write_page  # noqa: E402

import kalmanfield as kf  # noqa: E402

N_SAMPLES = 400
HORIZON = 50
R, Q, Q_VEL, P, P_VEL = 1.0, 0.05, 0.002, 2.0, 0.5
POSITION_JUMP = 4.0
VELOCITY_JUMP = 0.3
LEVELS = (0.3, 1.0, 3.0, 10.0)
_LEVELS_CHI2 = [1 - p for p in (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5)]
#: (label, method, options, confidences swept)
VARIANTS = [
    ("fuzzy", "fuzzy", {}, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.99]),
    ("chi2 W=1", "chi2", {"window": 1}, _LEVELS_CHI2),
    ("chi2 W=5", "chi2", {"window": 5}, _LEVELS_CHI2),
    ("chi2 W=10", "chi2", {"window": 10}, _LEVELS_CHI2),
    ("cusum k=0.5", "cusum", {"drift": 0.5}, _LEVELS_CHI2 + [1 - 3e-6]),
    ("cusum k=1", "cusum", {"drift": 1.0}, _LEVELS_CHI2 + [1 - 3e-6]),
]


def scenario(n_series: int, jump: str, noise: str, seed: int):
    """(z, jump times) of one scenario."""
    rng = np.random.default_rng(seed)
    t_jump = rng.integers(100, 300, n_series)
    sign = rng.choice([-1.0, 1.0], n_series)
    steps = np.arange(N_SAMPLES)
    vel = rng.normal(0, 0.2, (n_series, 1)) + np.cumsum(
        rng.normal(0, Q_VEL, (n_series, N_SAMPLES)), axis=1
    )
    after = steps[None, :] >= t_jump[:, None]
    if jump == "velocity":
        vel = vel + VELOCITY_JUMP * R * sign[:, None] * after
    x = np.cumsum(vel, axis=1) + np.cumsum(rng.normal(0, Q, (n_series, N_SAMPLES)), axis=1)
    if jump == "position":
        x = x + POSITION_JUMP * R * sign[:, None] * after
    if noise == "gaussian":
        e = rng.normal(0, R, x.shape)
    else:
        e = rng.standard_t(3, x.shape) * R / np.sqrt(3.0)
    return x + e, t_jump


def score(alarm: np.ndarray, t_jump: np.ndarray) -> tuple[float, float, float]:
    """(false alarms per 1,000 pre-jump samples, mean delay of the detected, detection rate)."""
    steps = np.arange(alarm.shape[1])
    before = alarm & (steps[None, :] < t_jump[:, None])
    false_rate = 1000.0 * before.sum() / t_jump.sum()
    window = (
        alarm & (steps[None, :] >= t_jump[:, None]) & (steps[None, :] < t_jump[:, None] + HORIZON)
    )
    hit = window.any(axis=1)
    first = np.where(hit, window.argmax(axis=1), -1)
    delays = (first - t_jump)[hit]
    return false_rate, float(delays.mean()) if hit.any() else np.nan, float(hit.mean())


def run_online(z, t_jump, method: str, options: dict, sweep: list[float]):
    rows = []
    filt = kf.FuzzyFilter(P, Q, R, P_VEL, Q_VEL)
    for c in sweep:
        found = kf.ChangeDetector(filt, method, confidence=c, **options).run(z)
        rows.append((c, *score(found.alarm, t_jump)))
    return rows


def run_ruptures(z, t_jump, penalties):
    import ruptures as rpt

    t = np.arange(N_SAMPLES, dtype=float)
    false_alarms = np.zeros(len(penalties))
    hits = np.zeros(len(penalties))
    delays: list[list[float]] = [[] for _ in penalties]
    for s in range(len(z)):
        signal = np.column_stack([z[s], t, np.ones_like(t)])
        algo = rpt.Binseg(model="linear", min_size=5).fit(signal)
        for i, pen in enumerate(penalties):
            bkps = np.array(algo.predict(pen=pen))
            bkps = bkps[bkps < N_SAMPLES]
            near = np.abs(bkps - t_jump[s])
            ok = near < HORIZON
            hits[i] += ok.any()
            false_alarms[i] += len(bkps) - ok.any()
            if ok.any():
                delays[i].append(near[ok].min())
    n = len(z)
    return [
        (pen, 1000.0 * fa / (n * N_SAMPLES), float(np.mean(d)) if d else np.nan, h / n)
        for pen, fa, d, h in zip(penalties, false_alarms, delays, hits)
    ]


def interpolate(rows, level: float) -> float:
    """The delay at `level` false alarms per 1,000 (log-linear; NaN outside the sweep or when
    the detection rate there is below 90 %)."""
    pts = sorted((fa, d) for _, fa, d, rate in rows if fa > 0 and rate >= 0.9 and np.isfinite(d))
    if len(pts) < 2:
        return np.nan
    fa, d = np.array(pts).T
    if not fa[0] <= level <= fa[-1]:
        return np.nan
    return float(np.interp(np.log(level), np.log(fa), d))


def plot(results, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(9, 6.5), sharex=True)
    for ax, ((jump, noise), res) in zip(axes.ravel(), results.items()):
        for i, (method, rows) in enumerate(res.items()):
            fa, d, rate = (np.array([r[j] for r in rows]) for j in (1, 2, 3))
            fa = np.maximum(fa, 1e-2)
            good = rate >= 0.9
            label = "ruptures (offline, |error|)" if method == "ruptures" else method
            style = "o" if method == "ruptures" else "-o"
            ax.plot(fa[good], d[good], style, ms=3, color=f"C{i}", label=label)
            ax.plot(fa[~good], d[~good], "x", ms=4, color=f"C{i}", alpha=0.6)
        ax.set_xscale("log")
        ax.set_title(f"{jump} jump, {noise} noise", fontsize=9)
        ax.set_ylabel("mean delay (samples)")
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("false alarms per 1,000 samples")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--series", type=int, default=2000)
    parser.add_argument("--ruptures-series", type=int, default=100)
    args = parser.parse_args()
    full_run = not args.quick and vars(args) == vars(parser.parse_args([]))
    n_series = 150 if args.quick else args.series
    try:
        import ruptures  # noqa: F401

        have_ruptures = True
    except ImportError:
        have_ruptures = False
    start = time.perf_counter()
    results = {}
    for k, (jump, noise) in enumerate(
        [(j, n) for j in ("position", "velocity") for n in ("gaussian", "student-t")]
    ):
        z, t_jump = scenario(n_series, jump, noise, seed=100 + k)
        res = {label: run_online(z, t_jump, m, o, sw) for label, m, o, sw in VARIANTS}
        if have_ruptures:
            m = min(n_series, 20 if args.quick else args.ruptures_series)
            res["ruptures"] = run_ruptures(z[:m], t_jump[:m], [5, 10, 20, 40, 80, 160])
        results[(jump, noise)] = res
    elapsed = time.perf_counter() - start

    lines = [
        "## Delay against false alarms",
        "",
        f"{n_series:,} series of {N_SAMPLES} samples per scenario, {elapsed:.0f} s. Position "
        f"jumps of {POSITION_JUMP:g} R, velocity jumps of {VELOCITY_JUMP:g} R per sample; R = 1, "
        f"Q = {Q}, Q' = {Q_VEL}; filters with the true spreads (a FuzzyFilter). Delay: mean over "
        f"the detected jumps (horizon {HORIZON}).",
        "",
        "Delay (samples) at a given false-alarm rate per 1,000 samples (interpolated; — where "
        "the sweep does not reach the rate or detects < 90 %):",
        "",
        "| scenario | method | " + " | ".join(f"{lv:g}/1000" for lv in LEVELS) + " |",
        "|---|---|" + "---:|" * len(LEVELS),
    ]
    labels = [v[0] for v in VARIANTS]
    wins: dict[str, int] = {}
    method_wins: dict[str, int] = {}
    for (jump, noise), res in results.items():
        for method in labels:
            cells = [interpolate(res[method], lv) for lv in LEVELS]
            lines.append(
                f"| {jump}, {noise} | {method} | "
                + " | ".join("—" if np.isnan(c) else f"{c:.1f}" for c in cells)
                + " |"
            )
        for lv in LEVELS:
            delays = {m: interpolate(res[m], lv) for m in labels}
            finite = {m: d for m, d in delays.items() if np.isfinite(d)}
            if finite:
                best = min(finite, key=finite.__getitem__)
                wins[best] = wins.get(best, 0) + 1
                method = best.split()[0]
                method_wins[method] = method_wins.get(method, 0) + 1
    lines += [
        "",
        f"Wins (smallest delay at one of the {len(LEVELS)} levels in one of the 4 scenarios): "
        + ", ".join(f"{m} {wins.get(m, 0)}" for m in labels)
        + "; per method: "
        + ", ".join(f"{m} {method_wins.get(m, 0)}" for m in ("fuzzy", "chi2", "cusum"))
        + ".",
        "",
    ]
    lines += [
        "Raw sweeps (confidence → false alarms per 1,000 / mean delay [detection rate]):",
        "",
        "| scenario | method | sweep |",
        "|---|---|---|",
    ]
    for (jump, noise), res in results.items():
        for method, rows in res.items():
            cells = "; ".join(
                f"{c:.6g} → {fa:.2f} / {d:.1f} [{rate:.0%}]" for c, fa, d, rate in rows
            )
            lines.append(f"| {jump}, {noise} | {method} | {cells} |")
    print("\n".join(lines))
    if not args.quick:
        images = ROOT / "docs" / "images" if full_run else SCRATCH
        plot(results, images / "trajectory_change_detection.png")
        lines += [
            "",
            "![delay against false alarms](../images/trajectory_change_detection.png)",
            "",
            "(Crosses: sweep points detecting fewer than 90 % of the jumps within the horizon.)",
        ]
    title = "Study: change detection"
    write_page("change_detection", title, "\n".join(lines), full_run=full_run)


if __name__ == "__main__":
    main()
