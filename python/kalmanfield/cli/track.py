"""``kalmanfield track``: frames (a folder, a TIFF stack, a video…) → tracks CSV + overlay
figure."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd
import tqdm

from ..io import iter_frames
from ..io._optional import optional
from ..tracking import BranchingTracker, segment
from ._common import OK, common, positive_float, positive_int, say


def _threshold(text: str) -> float | str:
    if text == "otsu":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a number or 'otsu' expected, got {text!r}") from None


def register(commands: argparse._SubParsersAction) -> None:
    p = commands.add_parser(
        "track",
        help="detect and track moving spots in frames: tracks CSV + overlay figure",
        description="Reads the frames one at a time (a folder of images, a TIFF stack, a "
        ".npy or zarr stack, a GIF or a video through imageio's ffmpeg plugin; colour is "
        "averaged to grey), segments each (pixels above the threshold), tracks the segments "
        "with the branching tracker and writes the tracks as CSV (frame, particle, x, y, "
        "…) and a figure of the tracks over the last frame.",
    )
    p.add_argument("frames", type=Path, help="folder, stack or video of the frames")
    p.add_argument("--out-dir", type=Path, default=Path("."), help="output folder (default .)")
    p.add_argument("--name", default=None, help="output file stem (default: the input's)")
    p.add_argument(
        "--threshold",
        type=_threshold,
        default="otsu",
        help="foreground threshold of every frame, or 'otsu' (default, per frame)",
    )
    p.add_argument(
        "--min-area", type=positive_int, default=1, help="smallest segment in pixels (default 1)"
    )
    p.add_argument("--invert", action="store_true", help="dark objects on a bright background")
    p.add_argument(
        "--measurement-std",
        type=positive_float,
        default=0.5,
        help="std of a detected position, px (default 0.5)",
    )
    p.add_argument(
        "--process-std",
        type=positive_float,
        default=0.2,
        help="std of the random acceleration, px/frame² (default 0.2)",
    )
    p.add_argument(
        "--max-misses",
        type=positive_int,
        default=3,
        help="longest run of frames a track coasts without a detection (default 3)",
    )
    p.add_argument("--max-frames", type=positive_int, help="stop after this many frames")
    p.add_argument("--no-figure", action="store_true", help="write the CSV only")
    common(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    if not args.no_figure:
        optional("matplotlib", "the overlay figure")  # before the work, not after
    tracker = BranchingTracker(
        2,
        measurement_std=args.measurement_std,
        process_std=args.process_std,
        max_misses=args.max_misses,
    )
    last = None
    n_frames = n_spots = 0
    frames = iter_frames(args.frames, grey=True)
    for frame in tqdm.tqdm(frames, desc="track", unit="frame", disable=args.quiet):
        image = -np.asarray(frame, np.float64) if args.invert else frame
        spots = segment(image, args.threshold, args.min_area)
        tracker.update(spots[["x", "y"]].to_numpy())
        last, n_frames, n_spots = frame, n_frames + 1, n_spots + len(spots)
        if args.max_frames is not None and n_frames >= args.max_frames:
            break
    if last is None:
        raise ValueError(f"{args.frames} holds no frame")
    tracks = tracker.tracks()
    stem = args.name or args.frames.stem
    args.out_dir.mkdir(parents=True, exist_ok=True)
    csv = args.out_dir / f"{stem}_tracks.csv"
    tracks.to_csv(csv, index=False)
    written = [csv]
    if not args.no_figure:
        written.append(args.out_dir / f"{stem}_tracks.png")
        _overlay(written[1], np.asarray(last), tracks, f"{args.frames.name}: {n_frames} frames")
    say(
        args,
        f"{n_frames} frames, {n_spots} segments, {tracks.particle.nunique()} tracks; "
        f"wrote {', '.join(map(str, written))}",
    )
    return OK


def _overlay(path: Path, frame: np.ndarray, tracks: pd.DataFrame, title: str) -> None:
    matplotlib = optional("matplotlib", "the overlay figure")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 7), constrained_layout=True)
    shown = ax.imshow(frame, cmap="gray")
    fig.colorbar(shown, ax=ax, shrink=0.8, label="intensity (last frame)")
    for particle, track in tracks.groupby("particle"):
        line = ax.plot(track.x, track.y, lw=1.5)[0]
        ax.annotate(
            str(particle),
            (track.x.iloc[-1], track.y.iloc[-1]),
            color=line.get_color(),
            fontsize=8,
            xytext=(3, 3),
            textcoords="offset points",
        )
    ax.set_xlim(-0.5, frame.shape[1] - 0.5)
    ax.set_ylim(frame.shape[0] - 0.5, -0.5)
    ax.set_xlabel("x (px)")
    ax.set_ylabel("y (px)")
    ax.set_title(f"tracks (numbered by particle) over the last frame\n{title}", fontsize=10)
    fig.savefig(path, dpi=100)
    plt.close(fig)
