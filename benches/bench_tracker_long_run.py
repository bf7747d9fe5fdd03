"""Long-run benchmark of the branching tracker (issue 49): time and memory per frame must not
depend on how many frames came before.

Scene: ``n_targets`` targets bouncing in a 500 × 500 box (1.5 px/frame, position noise
0.5 px) among 200 uniform clutter points per frame, tracked by ``BranchingTracker(2,
process_std=0.1, measurement_std=0.5)`` (defaults otherwise) for ``--frames`` frames. Every
``--every`` frames it reports the mean wall time per update over the last interval, the live
sequences, the mean bookkeeping records visited per frame (``stats()["bookkeeping"]``) and
the process's resident memory. The answers grow with the run by design: the finished tracks
(~80 bytes per track frame, in their own arena), the per-frame online answer (~41 bytes per
confirmed sequence and frame) and the per-frame statistics (56 bytes).

Run: ``python benches/bench_tracker_long_run.py [--frames 20000] [--targets 1 5]``; writes
the benchmark page ``docs/benchmarks/tracker_long_run.md`` (shorter runs: ``bench_out/``).
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np
from bench_page import write_page

import kalmanfield as kf

SIDE = 500.0


def resident_mb() -> float:
    """Resident memory of this process (Linux /proc; the peak elsewhere)."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return pages * resource.getpagesize() / 2**20
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def frames(n_frames: int, n_targets: int, n_clutter: int = 200, seed: int = 0):
    rng = np.random.default_rng(seed)
    position = rng.uniform(0.2 * SIDE, 0.8 * SIDE, (n_targets, 2))
    velocity = rng.choice([-1.5, 1.5], (n_targets, 2))
    for _ in range(n_frames):
        position += velocity
        out = (position < 0) | (position > SIDE)
        velocity[out] *= -1
        np.clip(position, 0, SIDE, out=position)
        noisy = position + rng.normal(0, 0.5, position.shape)
        yield np.vstack([noisy, rng.uniform(0, SIDE, (n_clutter, 2))])


def run(n_frames: int, n_targets: int, every: int) -> list[tuple]:
    tracker = kf.BranchingTracker(2, process_std=0.1, measurement_std=0.5)
    rows, elapsed = [], 0.0
    for f, z in enumerate(frames(n_frames, n_targets), start=1):
        t0 = time.perf_counter()
        tracker.update(z)
        elapsed += time.perf_counter() - t0
        if f % every == 0:
            stats = tracker.stats().iloc[-every:]
            rows.append(
                (
                    n_targets,
                    f,
                    1e3 * elapsed / every,
                    tracker.n_hypotheses,
                    stats["bookkeeping"].mean(),
                    resident_mb(),
                )
            )
            n, frame, ms, live, book, mb = rows[-1]
            print(f"{n} targets, frame {frame}: {ms:.2f} ms, live {live}, {book:.0f}, {mb:.0f} MB")
            elapsed = 0.0
    return rows


def main(argv=None) -> str:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=20_000)
    ap.add_argument("--every", type=int, default=2_000)
    ap.add_argument("--targets", type=int, nargs="+", default=[1, 5])
    args = ap.parse_args(argv)
    lines = [
        "Scene: targets bouncing in a 500 × 500 box (1.5 px/frame, position noise 0.5 px) "
        "among 200 uniform clutter points per frame, `BranchingTracker(2, process_std=0.1, "
        "measurement_std=0.5)`; one thread; wall time per `update` averaged over each "
        "interval, the live sequences, the bookkeeping records visited per frame and the "
        "process's resident memory at the end of the interval.",
        "",
        "| targets | frame | ms/frame | live sequences | bookkeeping/frame | resident MB |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for n_targets in args.targets:
        for row in run(args.frames, n_targets, args.every):
            n, frame, ms, live, book, mb = row
            lines.append(f"| {n} | {frame} | {ms:.2f} | {live} | {book:.0f} | {mb:.0f} |")
    text = "\n".join(lines) + "\n"
    title = "Benchmark: the branching tracker over long runs"
    write_page("tracker_long_run", title, text, full_run=args.frames >= 20_000)
    return text


if __name__ == "__main__":
    print(main())
