"""Linking Brownian and directed particles (trackpy's home ground): ``kalmanfield.link`` with
its default arguments against trackpy, in one run.

The scene (``brownian_scenario.py``): 40 Brownian particles (steps of 1 px std per axis) and 6
directed ones (4 px/frame, bouncing off the borders) in 256 × 256 px, 100 frames, localisation
noise 0.1 px; without clutter (every particle detected), and with P_d 0.9 and 50 uniform
clutter points per frame.

Linkers, on the same detections:

1. ``kalmanfield.link(detections)``: default arguments (``motion="auto"``, every noise level
   estimated from the table); also ``motion="diffusion"``;
2. trackpy ``link(search_range=5, memory=3)`` (the issue's call), if trackpy is installed.

Scores (``brownian_scenario.py``): the share of consecutive detections of a true particle
that carry one label (Brownian and directed particles apart), and the precision of the links
(the share of consecutive detections of an output track that belong to one particle: clutter
joined to a track counts against it). CPU seconds of the linker alone.

Run: ``python benches/bench_linking.py [--seeds 1 2 3] [--quick]``. The Markdown report is
printed and written to ``docs/benchmarks/linking.md`` (``--quick``: to
``bench_out/linking.md``).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_page import write_page  # noqa: E402
from brownian_scenario import (  # noqa: E402
    BrownianScenario,
    link_precision,
    make_brownian,
    pair_accuracy,
)

import kalmanfield as kf  # noqa: E402

SCENES = {"no clutter": {}, "P_d 0.9, 50 clutter/frame": dict(p_detect=0.9, n_clutter=50)}

HEADER = (
    "| linker | scene | seed | Brownian pairs | directed pairs | link precision | CPU (s) |\n"
    "|---|---|---|---|---|---|---|"
)


def run_kf(motion: str) -> Callable[[BrownianScenario], tuple[pd.Series, float]]:
    def run(sc: BrownianScenario) -> tuple[pd.Series, float]:
        t0 = time.process_time()
        out = kf.link(sc.detections[["frame", "x", "y"]], motion=motion)
        return out.particle, time.process_time() - t0

    return run


def run_trackpy(sc: BrownianScenario) -> tuple[pd.Series, float]:
    import trackpy as tp

    tp.quiet()
    t0 = time.process_time()
    out = tp.link(sc.detections[["frame", "x", "y"]], search_range=5, memory=3)
    return out.particle, time.process_time() - t0


def reading(summary: dict[tuple[str, str], list]) -> list[str]:
    """The comparison the issue asks for, in words: `kf.link()` on its defaults against
    trackpy's call, scene by scene (means over the seeds of this run)."""
    tp_name = next((n for n, _ in summary if n.startswith("trackpy")), None)
    if tp_name is None:
        return []
    out = ["Reading (means over the seeds of this run, `kf.link()` on its defaults / trackpy):", ""]
    for scene in SCENES:
        b, d, p, cpu = np.mean(summary[("kf.link() defaults", scene)], axis=0)
        tb, td, tpp, tcpu = np.mean(summary[(tp_name, scene)], axis=0)
        out.append(
            f"- {scene}: Brownian pairs {b:.4f} / {tb:.4f}, directed pairs {d:.4f} / {td:.4f}, "
            f"link precision {p:.4f} / {tpp:.4f}; CPU {cpu / tcpu:.1f}× trackpy's."
        )
    return out


def main(argv=None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    seeds = args.seeds[:1] if args.quick else args.seeds
    runners: dict[str, Callable] = {
        "kf.link() defaults": run_kf("auto"),
        'kf.link(motion="diffusion")': run_kf("diffusion"),
    }
    try:
        import trackpy  # noqa: F401

        runners["trackpy link(search_range=5, memory=3)"] = run_trackpy
    except ImportError:
        print("trackpy not installed: skipped")
    lines = [
        "## Brownian and directed particles",
        "",
        "40 Brownian particles (steps of 1 px std per axis) and 6 directed ones (4 px/frame, "
        "bouncing off the borders) in 256 × 256 px, 100 frames, localisation noise 0.1 px "
        "(`benches/brownian_scenario.py`); without clutter, and with P_d 0.9 and 50 uniform "
        "clutter points per frame. *Pairs*: the share of consecutive detections of a true "
        "particle that carry one label; *link precision*: the share of consecutive "
        "detections of an output track that belong to one particle. CPU seconds of the "
        "linker alone.",
        "",
        HEADER,
    ]
    summary: dict[tuple[str, str], list] = {}
    for scene, over in SCENES.items():
        for seed in seeds:
            sc = make_brownian(seed, **over)
            for name, fn in runners.items():
                particle, cpu = fn(sc)
                brownian, directed = pair_accuracy(sc, particle)
                precision = link_precision(sc, particle)
                figures = (brownian, directed, precision, cpu)
                summary.setdefault((name, scene), []).append(figures)
                row = (
                    f"| {name} | {scene} | {seed} | {brownian:.4f} | {directed:.4f} | "
                    f"{precision:.4f} | {cpu:.2f} |"
                )
                print(row, flush=True)
                lines.append(row)
    if len(seeds) > 1:
        lines += ["", "Mean over seeds:", "", HEADER]
        for (name, scene), vals in summary.items():
            b, d, p, cpu = np.mean(vals, axis=0)
            lines.append(f"| {name} | {scene} | mean | {b:.4f} | {d:.4f} | {p:.4f} | {cpu:.2f} |")
    lines += ["", *reading(summary)]
    text = "\n".join(lines) + "\n"
    print()
    print(text)
    write_page(
        "linking", "Benchmark: linking particles against trackpy", text, full_run=not args.quick
    )
    return text


if __name__ == "__main__":
    main()
