"""Scale benchmark of the detect-and-track pipeline (issue 5): segmentation + branching tracker.

Scenario: ``tracking_scenario.make_scenario(size=512, n_targets=50, n_clutter=200)`` (100
frames, targets at ~2 px/frame bouncing off the borders, P_d = 0.9, position noise 0.5 px),
every detection (target or clutter) rendered by ``tracking_frames.render`` as a float32 Gaussian
spot (σ = 1 px, amplitude 100) in white noise of std 5. Per frame, timed on one thread:

1. ``kalmanfield.segment(image, threshold=25)`` (5 noise std) → DataFrame of segments;
2. ``BranchingTracker.update(segments[["x", "y"]])`` with ``bench_tracking.TRACKER_CONFIG``
   (the anchor configuration) and the scenario's clutter density.

Reported: frames per second of segmentation alone, tracking alone and the pipeline (CPU time,
``time.process_time``, best of ``--repeats`` passes; rendering is not timed), the live
sequences per frame, and IDF1/MOTA of ``tracks()`` against the true positions (py-motmetrics,
3 px), so speed is never bought with quality. The same tracker on the scenario's ideal point
detections (no image) is the second row.

Run: ``python benches/bench_tracking_scale.py [--seeds 1 2] [--repeats 3]``; writes the
benchmark page ``docs/benchmarks/tracking_scale.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_page import write_page  # noqa: E402
from bench_tracking import TRACKER_CONFIG, score  # noqa: E402
from tracking_frames import render  # noqa: E402
from tracking_scenario import make_scenario  # noqa: E402

import kalmanfield as kf  # noqa: E402

THRESHOLD = 25.0


def run_pipeline(images, clutter_density: float, segment: bool = True, points=None):
    """(tracks, segmentation CPU s, tracking CPU s, mean live sequences) of one pass."""
    tracker = kf.BranchingTracker(2, clutter_density=clutter_density, **TRACKER_CONFIG)
    t_seg = t_track = 0.0
    for image in images if segment else points:
        t0 = time.process_time()
        xy = kf.segment(image, THRESHOLD) if segment else image
        t1 = time.process_time()
        tracker.update(xy)
        t2 = time.process_time()
        t_seg += t1 - t0
        t_track += t2 - t1
    live = float(tracker.stats()["live"].mean())
    return tracker.tracks(), t_seg, t_track, live


def main(argv=None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    lines = [
        "## Scale: 512 × 512, 50 targets, 200 clutter points per frame (one thread)",
        "",
        f"CPU time, best of {args.repeats} passes over 100 frames.",
        "",
        "| input | seed | segment (fps) | track (fps) | pipeline (fps) | live seq. | IDF1 | MOTA |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for seed in args.seeds:
        sc = make_scenario(seed, size=512.0, n_targets=50, n_clutter=200)
        rng = np.random.default_rng(seed)
        points = sc.frames()
        images = [render(xy, (512, 512), rng=rng) for xy in points]
        n = len(images)
        for label, segment in [("rendered frames", True), ("ideal detections", False)]:
            best = None
            for _ in range(args.repeats):
                out = run_pipeline(images, sc.clutter_density, segment, points)
                if best is None or out[1] + out[2] < best[1] + best[2]:
                    best = out
            tracks, t_seg, t_track, live = best
            m = score(sc.truth, tracks[["frame", "particle", "x", "y"]], n)
            seg_fps = f"{n / t_seg:.0f}" if segment else "–"
            row = (
                f"| {label} | {seed} | {seg_fps} | {n / t_track:.0f} | "
                f"{n / (t_seg + t_track):.0f} | {live:.0f} | {m['idf1']:.3f} | {m['mota']:.3f} |"
            )
            print(row, flush=True)
            lines.append(row)
    text = "\n".join(lines) + "\n"
    print()
    print(text)
    full_run = args.repeats >= 3
    write_page("tracking_scale", "Benchmark: detect and track at scale", text, full_run=full_run)
    return text


if __name__ == "__main__":
    main()
