"""Speed of ``kalmanfield.segment`` (method page *Tracking*, §3) on tracker-benchmark frames.

Frames: the scenario of ``tracking_scenario.py`` scaled to 512 × 512 px (50 targets, 200
clutter points, ~245 detections per frame), rendered by ``tracking_frames.render`` as float32
Gaussian spots (σ = 1 px, amplitude 100) in white noise of std 5; threshold 25 (5 noise std),
8-connectivity, min_area 1.

Methods, each giving per segment the label, the centroid of the excess over the threshold, the
area and the bounding box:

1. ``kalmanfield.segment`` (the DataFrame) and the bare binding ``_core.segment`` (dict of
   arrays), one thread;
2. ``scipy.ndimage``: ``label`` + ``center_of_mass`` of the excess image + ``find_objects`` +
   ``bincount`` for the areas;
3. ``skimage.measure``: ``label`` + ``regionprops_table`` (label, area, centroid_weighted,
   bbox), if scikit-image is installed.

Time: wall-clock per frame, best of ``--repeats`` passes over the frames (the machine may be
shared). The segment counts and the centroids of the methods are cross-checked (outside
the timed loop).

Run: ``python benches/bench_segment.py [--frames 50] [--repeats 3]``; prints a Markdown table and
writes it to the benchmark page ``docs/benchmarks/segment.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_page import write_page  # noqa: E402
from tracking_frames import render  # noqa: E402
from tracking_scenario import make_scenario  # noqa: E402

import kalmanfield as kf  # noqa: E402
from kalmanfield import _core  # noqa: E402

SIZE = 512
THRESHOLD = 25.0
EIGHT = ndimage.generate_binary_structure(2, 2)


def frames(n_frames: int, seed: int = 1) -> list[np.ndarray]:
    """The rendered frames of one seeded 512 × 512 scenario."""
    sc = make_scenario(seed, size=float(SIZE), n_targets=50, n_clutter=200, n_frames=n_frames)
    rng = np.random.default_rng(seed)
    return [render(xy, (SIZE, SIZE), psf_sigma=1.0, rng=rng) for xy in sc.frames()]


def with_kalmanfield(frame: np.ndarray) -> pd.DataFrame:
    return kf.segment(frame, THRESHOLD)


def with_core(frame: np.ndarray) -> tuple[dict, np.ndarray]:
    return _core.segment(frame, THRESHOLD, 1, 8)


def with_scipy(frame: np.ndarray) -> list:
    mask = frame > THRESHOLD
    labels, n = ndimage.label(mask, EIGHT)
    excess = np.where(mask, frame.astype(np.float64) - THRESHOLD, 0.0)
    centres = ndimage.center_of_mass(excess, labels, np.arange(1, n + 1))
    return [centres, ndimage.find_objects(labels), np.bincount(labels.ravel())]


def with_skimage(frame: np.ndarray) -> dict:
    from skimage import measure

    mask = frame > THRESHOLD
    labels = measure.label(mask, connectivity=2)
    excess = np.where(mask, frame.astype(np.float64) - THRESHOLD, 0.0)
    return measure.regionprops_table(
        labels, excess, properties=("label", "area", "centroid_weighted", "bbox")
    )


def centres(name: str, result) -> np.ndarray:
    """The (x, y) centroids in a method's result, for the cross-check (not timed)."""
    if name.startswith("kalmanfield.segment"):
        return result[["x", "y"]].to_numpy()
    if name.startswith("kalmanfield._core"):
        return np.column_stack([result[0]["x"], result[0]["y"]])
    if name.startswith("scipy"):
        return np.array(result[0])[:, ::-1]
    return np.column_stack([result["centroid_weighted-1"], result["centroid_weighted-0"]])


def seconds_per_frame(method: Callable, images: list[np.ndarray], repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.perf_counter()
        for image in images:
            method(image)
        best = min(best, time.perf_counter() - start)
    return best / len(images)


def methods() -> dict[str, Callable]:
    found = {
        "kalmanfield.segment (DataFrame)": with_kalmanfield,
        "kalmanfield._core.segment (dict)": with_core,
        "scipy.ndimage label + center_of_mass + find_objects": with_scipy,
    }
    try:
        import skimage  # noqa: F401

        found["skimage.measure label + regionprops_table"] = with_skimage
    except ImportError:
        pass
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    images = frames(args.frames)
    reference = [centres("scipy", with_scipy(image)) for image in images]
    n_segments = np.mean([len(r) for r in reference])

    lines = [
        f"Segmentation of {len(images)} float32 {SIZE}×{SIZE} frames, ~{n_segments:.0f} "
        f"segments/frame (threshold {THRESHOLD:g}, 8-connectivity); best of {args.repeats}.",
        "",
        "| method | ms/frame | frames/s |",
        "|---|---:|---:|",
    ]
    for name, method in methods().items():
        for image, expected in zip(images, reference):
            got = centres(name, method(image))
            assert got.shape == expected.shape, name
            np.testing.assert_allclose(got, expected, atol=1e-9, err_msg=name)
        t = seconds_per_frame(method, images, args.repeats)
        lines.append(f"| {name} | {1e3 * t:.3f} | {1 / t:,.0f} |")
    print("\n".join(lines))
    write_page("segment", "Benchmark: segmentation", "\n".join(lines), full_run=args.frames >= 50)


if __name__ == "__main__":
    main()
