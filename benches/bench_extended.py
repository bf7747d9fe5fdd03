"""Benchmark and study of the extended-object detector (method page *Extended objects*, §3.5):
the source's P_o table with 95 % Wilson intervals, the same with an AR-field background (the
white-noise threshold and the local-background option), P_o against SNR and P_f, identities
on multi-object extended scenes (motmetrics, optional), and the cost of detect_moving_objects
against segmentation alone.

Run: ``python benches/bench_extended.py [--quick]``; the report is printed and written to
``docs/benchmarks/extended.md`` with the figures ``docs/images/extended_k93.png`` and
``docs/images/guide_extended.png`` (``--quick``: a few runs per cell, the page goes to
``bench_out/extended.md`` and no figure is written). Build the extension with the release
profile first.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_page import ROOT, write_page  # noqa: E402

import kalmanfield as kf  # noqa: E402
from kalmanfield.experiments import k93, plot_k93  # noqa: E402

IMAGES = ROOT / "docs" / "images"
#: the local-background settings of the AR table (chosen on 150 runs per cell of seed 7, a
#: study seed the table does not use: method page, §3.4 "Textured backgrounds")
AR_OPTIONS = {"background_width": 25, "threshold_k": 5.0, "min_area": 20}


def table_md(t) -> str:
    lines = [
        "| SNR | P_f | runs | correct | P_o | 95 % interval | source P_o |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in t.itertuples():
        src = "–" if np.isnan(r.source) else f"{r.source:.2f}"
        lines.append(
            f"| {r.snr:g} | {r.p_false:g} | {r.runs} | {r.correct} | {r.p_o:.3f} | "
            f"[{r.low:.3f}, {r.high:.3f}] | {src} |"
        )
    return "\n".join(lines)


def best_of(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def speed(quick: bool) -> str:
    rows = [
        "| scene | frames | segment alone (ms/frame) | detect_moving_objects (ms/frame) | ratio |",
        "|---|---|---|---|---|",
    ]
    scenes = [
        ("64² source scene", kf.simulate_scene((64, 64), 10, snr=3.0, p_false=0.3, dt=0.1, seed=1)),
        (
            "512², 40-px object, 50 spots per frame",
            kf.simulate_scene(
                (512, 512),
                6 if quick else 20,
                targets=[kf.Target(size=40.0)],
                snr=3.0,
                p_false=1.0,
                dt=0.1,
                seed=2,
                spots=50,
            ),
        ),
    ]
    repeat = 1 if quick else 5
    for name, s in scenes:
        frames = s.frames
        threshold = float(np.median(frames)) + 3.0
        seg = best_of(lambda f=frames, t=threshold: [kf.segment(x, t, 3) for x in f], repeat)
        det = best_of(lambda f=frames: kf.detect_moving_objects(f, noise_std=1.0, dt=0.1), repeat)
        n = len(frames)
        rows.append(
            f"| {name} | {n} | {1e3 * seg / n:.2f} | {1e3 * det / n:.2f} | {det / seg:.1f}× |"
        )
    return "\n".join(rows) + "\n\n" + parts(scenes[1][1].frames, repeat)


def parts(frames, repeat: int) -> str:
    """Per-frame cost of the detector's steps on the 512² scene (ms), best of `repeat`."""
    from kalmanfield import _core
    from kalmanfield.extended.frames import FrameCheck, segment_frame
    from kalmanfield.extended.options import DetectorOptions

    check = FrameCheck()
    smoothed = [_core.extended_smooth(f, 3) for f in frames]
    level = _core.extended_level(smoothed[0])
    buffer = np.empty_like(smoothed[0])
    tables = [segment_frame(m, level + 1.0, 3, 8)[0] for m in smoothed]
    config = DetectorOptions().core_config(
        dt=0.1, noise_std=1.0, confidence=0.99, memory=4, seed_groups=True
    )

    def stage2() -> None:
        tracker = _core.GroupTracker(**config)
        for z in tables:
            tracker.step(z)

    steps = {
        "frame check (float64 view, finiteness)": lambda: [check.frame(f, 0) for f in frames],
        "3 × 3 box mean (Rust), into the reused buffer": lambda: [
            _core.extended_smooth(f, 3, buffer) for f in frames
        ],
        "3 × 3 box mean (Rust), into a new array": lambda: [
            _core.extended_smooth(f, 3) for f in frames
        ],
        "median (Rust)": lambda: [_core.extended_level(m) for m in smoothed],
        "segmentation + table": lambda: [segment_frame(m, level + 1.0, 3, 8) for m in smoothed],
        "stage 2 (GroupTracker.step)": stage2,
        "kf.segment (the anchor)": lambda: [kf.segment(m, level + 1.0, 3) for m in smoothed],
    }
    n = len(frames)
    lines = ["| step (512² scene) | ms/frame |", "|---|---|"]
    for name, fn in steps.items():
        lines.append(f"| {name} | {1e3 * best_of(fn, repeat) / n:.2f} |")
    return "\n".join(lines)


def crossing_scene(kind: str, seed: int, p_vanish: float) -> kf.Scene:
    """Three-stripe targets (p_vanish per stripe and frame), 96 × 96, 24 frames, τ = 0.1,
    P_f = 0.3, σ = 1, SNR 5, no foreign objects. "passing": two 12-px targets pass each
    other 16 px apart (3 px/frame each way) while a third crosses both paths at other times;
    "x": two 10-px targets on X-shaped paths through one point, there 8 frames apart;
    "head-on": two 12-px targets meet on one line (full occlusion)."""
    n = 24
    t = np.arange(n)[:, None]
    if kind == "passing":
        paths = [
            np.hstack([14 + 3.0 * t, 40 + 0 * t]),
            np.hstack([82 - 3.0 * t, 56 + 0 * t]),
            np.hstack([28 + 0 * t, 90 - 3.0 * t]),
        ]
        size = 12.0
    elif kind == "x":
        paths = [
            np.hstack([48 + 3.0 * (t - 8), 48 + 2.0 * (t - 8)]),
            np.hstack([48 - 3.0 * (t - 16), 48 + 2.0 * (t - 16)]),
        ]
        size = 10.0
    else:
        paths = [np.hstack([18 + 3.0 * t, 48 + 0 * t]), np.hstack([78 - 3.0 * t, 48 + 0 * t])]
        size = 12.0
    targets = [kf.Target(size=size, fragments=3, p_vanish=p_vanish, trajectory=p) for p in paths]
    return kf.simulate_scene(
        (96, 96),
        n,
        targets=targets,
        snr=5.0,
        p_false=0.3,
        dt=0.1,
        seed=seed,
        still_objects=0,
        moving_objects=0,
    )


def mot_summary(mm, scene: kf.Scene, objects: list):
    """motmetrics summary of one scene: true against detected centres, 6-px gate."""
    acc = mm.MOTAccumulator(auto_id=True)
    rows = [(o.id, r.frame, r.x, r.y) for o in objects for r in o.track.itertuples()]
    for f in range(scene.frames.shape[0]):
        truth = scene.truth[scene.truth["frame"] == f]
        hyp = [(i, x, y) for i, g, x, y in rows if g == f]
        d = mm.distances.norm2squared_matrix(
            truth[["x", "y"]].to_numpy(),
            np.array([h[1:] for h in hyp]).reshape(-1, 2),
            max_d2=36.0,
        )
        acc.update(truth["target"].tolist(), [h[0] for h in hyp], d)
    metrics = ["num_objects", "num_switches", "num_fragmentations", "idf1", "mota"]
    return mm.metrics.create().compute(acc, metrics=metrics).iloc[0]


def identities(quick: bool) -> str:
    try:
        import motmetrics as mm
    except ImportError:
        return "motmetrics is not installed: section skipped."
    scenes = 1 if quick else 20
    lines = [
        "| scene | p_vanish | scenes | target-frames | ID switches | fragmentations "
        "| IDF1 | MOTA |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for kind in ("x", "passing", "head-on"):
        for p_vanish in (0.0, 0.25):
            rows = []
            for seed in range(scenes):
                s = crossing_scene(kind, seed, p_vanish)
                objects = kf.detect_moving_objects(s.frames, noise_std=1.0, dt=0.1)
                rows.append(mot_summary(mm, s, objects))
            n = sum(int(r.num_objects) for r in rows)
            switches = sum(int(r.num_switches) for r in rows)
            frag = sum(int(r.num_fragmentations) for r in rows)
            idf1 = np.mean([r.idf1 for r in rows])
            mota = np.mean([r.mota for r in rows])
            lines.append(
                f"| {kind} | {p_vanish:g} | {scenes} | {n} | {switches} | {frag} | "
                f"{idf1:.2f} | {mota:.2f} |"
            )
    return "\n".join(lines)


def guide_figure(path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    target = kf.Target(fragments=3, p_vanish=0.2)
    s = kf.simulate_scene((64, 64), 10, targets=[target], snr=4.0, p_false=0.3, dt=0.1, seed=11)
    obj = kf.detect_moving_objects(s.frames, noise_std=1.0, dt=0.1)[0]
    last = int(obj.frames[-1])
    fig, ax = plt.subplots(figsize=(4, 4))
    ax.imshow(s.frames[last], cmap="gray")
    ax.contour(obj.mask(last), levels=[0.5], colors="tab:red", linewidths=1)
    ax.plot(obj.track["x"], obj.track["y"], "-o", color="tab:orange", ms=3, label="detected track")
    truth = s.truth
    ax.plot(truth["x"], truth["y"], "--", color="tab:cyan", lw=1, label="true centre")
    ax.set_title(f"frame {last}: detected object (red outline)", fontsize=9)
    ax.legend(fontsize=7, loc="lower left")
    ax.set_axis_off()
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    full_run = not args.quick
    runs = 10 if args.quick else 500
    side = 5 if args.quick else 200
    t0 = time.perf_counter()
    table = k93(runs=runs, progress=not args.quick)
    ar = kf.ARFieldModel(rho=(0.5, 0.9, 0.9), order=1, sigma=1.0)
    ar_table = k93(runs=runs, background=ar, progress=not args.quick, threshold_k=6.0)
    ar_local = k93(runs=runs, background=ar, progress=not args.quick, **AR_OPTIONS)
    by_snr = k93(snr=(1, 2, 3, 4, 5, 6), p_false=(0.3,), runs=side, seed=1, progress=not args.quick)
    by_pf = k93(
        snr=(3,), p_false=(0.0, 0.1, 0.3, 0.5, 1.0), runs=side, seed=2, progress=not args.quick
    )
    ids = identities(args.quick)
    speeds = speed(args.quick)
    elapsed = time.perf_counter() - t0
    text = f"""
## The source's table

Each cell: {runs} scenes of the source's experiment (10 frames of 64 × 64, τ = 0.1, a rhombus of
side 10 moving by the model (3.7), clutter spots in a frame with probability P_f, one still and
one slower moving foreign rhombus, white noise σ = 1; `kalmanfield.simulate_scene` defaults),
detected by `detect_moving_objects(frames, noise_std=1, dt=0.1)` and judged by the 3σ rule of
`kalmanfield.experiments.k93_correct` (the best-ranked object is detected in the last frame, its
centre within 3 px of the true centre per axis, its velocity within 30 px/s per axis).
Intervals: 95 % Wilson.

{table_md(table)}

## With an AR-field background

The same scenes plus a space–time AR field (ρ = 0.5 in time, 0.9 along rows and columns,
σ = 1) as textured clutter, {runs} runs per cell. The detector is told the white-noise σ = 1
only. First with the white-noise threshold raised to `threshold_k=6` (2σ above the smoothed
frame's median; at 3σ/3 the texture passes everywhere):

{table_md(ar_table)}

Then with the local-background option `{AR_OPTIONS}`: the mean over a 25 × 25 box of the
smoothed frame is subtracted before thresholding (the texture's slow part goes, the 10-px
target stays), threshold 5σ/3 above the median, segments under 20 pixels dropped (texture
blobs; the target's segment has 60–100). These settings were chosen on 150 runs per cell of
another seed (7) among 26 candidates, with the ranking capped by the net displacement (method
page, §3.4). Before that cap, with `min_area=9`, this table read 0.814 / 0.858 / 0.928 / 0.966
(run of 2026-12-02): a still foreign object whose segment merged with texture blobs had a
jittering centre, a large filtered speed, and outranked the target.

{table_md(ar_local)}

## P_o against SNR (P_f = 0.3) and against P_f (SNR 3)

{side} runs per point.

{table_md(by_snr)}

{table_md(by_pf)}

## Identities on multi-object extended scenes

`detect_moving_objects(frames, noise_std=1, dt=0.1)` on scenes of fragmented targets
(`crossing_scene` in the script: three vertical stripes per target with 1-px gaps, each dark
in a frame with probability p_vanish; 96 × 96, 24 frames, SNR 5, P_f = 0.3), scored by
motmetrics (object centre against true centre, 6-px gate: half a target), summed over the
scenes (IDF1 and MOTA: mean over the scenes). "x": two targets on crossing paths, at the
crossing 8 frames apart; "passing": two targets pass each other 16 px apart while a third
crosses both paths; "head-on": two targets meet on one line (they occlude each other).

{ids}

Before the occlusion rule (hidden objects coast through a merged segment) and the velocity
memory of a group whose sequences all restarted (method page, §3.4), the same scenes and seeds
gave (run of 2026-12-02, morning):

| scene | p_vanish | scenes | target-frames | ID switches | fragmentations | IDF1 | MOTA |
|---|---|---|---|---|---|---|---|
| x | 0 | 20 | 960 | 1 | 20 | 0.94 | 0.89 |
| x | 0.25 | 20 | 960 | 31 | 49 | 0.78 | 0.77 |
| passing | 0 | 20 | 1440 | 49 | 65 | 0.59 | 0.61 |
| passing | 0.25 | 20 | 1440 | 74 | 106 | 0.61 | 0.59 |
| head-on | 0 | 20 | 960 | 28 | 29 | 0.63 | 0.67 |
| head-on | 0.25 | 20 | 960 | 55 | 72 | 0.52 | 0.56 |

and before the partial-segment variance, the precision-weighted group velocity and the held
box (run of 2026-12-02):

| scene | p_vanish | scenes | target-frames | ID switches | fragmentations | IDF1 | MOTA |
|---|---|---|---|---|---|---|---|
| x | 0 | 20 | 960 | 1 | 28 | 0.93 | 0.87 |
| x | 0.25 | 20 | 960 | 64 | 76 | 0.59 | 0.67 |
| passing | 0 | 20 | 1440 | 51 | 67 | 0.56 | 0.55 |
| passing | 0.25 | 20 | 1440 | 102 | 134 | 0.49 | 0.49 |
| head-on | 0 | 20 | 960 | 44 | 55 | 0.47 | 0.56 |
| head-on | 0.25 | 20 | 960 | 75 | 84 | 0.49 | 0.51 |

Measured on the way (this script, same seeds): a first form of the partial-segment variance
used any change of the box extent, Δ, without asking that one edge be kept: IDF1 0.90 / 0.69 /
0.61 / 0.59 / 0.57 / 0.51 (rows in the order above), but on the AR-field background the table
fell to P_o 0.30 / 0.37 / 0.58 / 0.74 (threshold_k 6) and 0.78 / 0.78 / 0.85 / 0.94 (local
background): texture blobs change the extent of every segment, and the inflated variance let
sequences jump between blobs. With the plain mean velocity (no precision weights) that form
gave IDF1 0.90 / 0.68 / 0.60 / 0.57 / 0.54 / 0.53.

## Cost against segmentation alone

`kf.segment` of every frame at a fixed threshold against the whole detector (box smoothing,
threshold, segmentation, stage 2, records), best of {1 if args.quick else 5} runs. The second
table splits the 512² frame's cost: what the detector adds to segmentation is the frame check
(a float64 view and one finiteness reduction), the 3 × 3 box mean (into a buffer the detector
reuses: a new 512² float64 array costs more in page faults than the arithmetic) and the median
(Rust), then stage 2 (every live sequence against every segment: with 50 clutter spots per
frame some 150 young groups are alive) and the records. The anchor `kf.segment` builds a
DataFrame per frame; the detector's segmentation keeps arrays.

{speeds}

Study time: {elapsed:.0f} s.
"""
    print(text)
    if full_run:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        ax = plot_k93(table)
        ax.figure.tight_layout()
        ax.figure.savefig(IMAGES / "extended_k93.png", dpi=80)
        plt.close(ax.figure)
        guide_figure(IMAGES / "guide_extended.png")
    write_page("extended", "Benchmark: extended objects", text, full_run=full_run)


if __name__ == "__main__":
    main()
