"""``kalmanfield demo``: the main job, from a simulated scene to identified objects, written
as a report."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import OK, at_least, common, nonnegative_int, positive_float, positive_int

#: the smallest frame side and frame count the demo runs with
MIN_SIZE, MIN_FRAMES = 64, 20


def register(commands: argparse._SubParsersAction) -> None:
    p = commands.add_parser(
        "demo",
        help="simulate a scene, denoise, detect, track, find change points, identify types; "
        "write an HTML report",
        description="Simulates point targets of two motion types and extended objects made "
        "of fragments over AR-field clutter plus white noise; estimates the clutter with the "
        "row Kalman filter, detects the targets in the residual, tracks them "
        "(BranchingTracker), finds their velocity changes (ChangeDetector), identifies their "
        "types (TypeIdentifier), detects the extended objects (detect_moving_objects); scores "
        "it all against "
        "the truth and writes OUT/index.html (self-contained, figures embedded), "
        "OUT/tracks.gif, OUT/tracks.csv and OUT/numbers.json.",
    )
    p.add_argument(
        "--out", type=Path, default=Path("demo_out"), help="report folder (default demo_out)"
    )
    p.add_argument(
        "--size",
        type=at_least(MIN_SIZE),
        default=256,
        help=f"frame side in px (default 256, at least {MIN_SIZE})",
    )
    p.add_argument(
        "--frames",
        type=at_least(MIN_FRAMES),
        default=60,
        help=f"number of frames (default 60, at least {MIN_FRAMES})",
    )
    p.add_argument("--targets", type=positive_int, default=8, help="point targets (default 8)")
    p.add_argument(
        "--extended",
        type=nonnegative_int,
        default=2,
        help="extended objects, each three fragments moving together (default 2)",
    )
    p.add_argument(
        "--noise-std",
        type=positive_float,
        default=1.0,
        help="std of the white noise (default 1; the clutter's is 1)",
    )
    p.add_argument(
        "--save-arrays",
        action="store_true",
        help="also save the frames as .npy and the truth as CSV",
    )
    common(p, seed=2026)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    from ..report import DemoSettings, run_demo

    settings = DemoSettings(
        out=args.out,
        size=args.size,
        n_frames=args.frames,
        n_targets=args.targets,
        n_extended=args.extended,
        noise_std=args.noise_std,
        seed=args.seed,
        save_arrays=args.save_arrays,
        progress=not args.quiet,
    )
    result = run_demo(settings)
    n = result.numbers
    mse = n["filtering"]["mse"]
    tracking, changes = n["tracking"], n["change_points"]
    delay = changes["mean_delay_frames"]
    print(
        f"clutter estimate MSE {mse['row filter, model fitted to the noisy frames']:.4f} "
        f"(Wiener bound {mse['Wiener bound (no estimator of the clutter does better)']:.4f}); "
        f"IDF1 {tracking['idf1']:.3f}, MOTA {tracking['mota']:.3f}; "
        f"{changes['detected']}/{changes['true_changes']} changes found"
        + (f" (mean delay {delay:.1f} frames)" if delay is not None else "")
        + f"; types right for {n['types']['correct']}/{n['types']['targets']} targets"
        + "".join(
            f"; extended object {r['object']} P_o {r['P_o']:.2f}"
            for r in n["extended_objects"]["per_object"]
        )
    )
    print(f"report: {result.files['report'].resolve()}")
    return OK
