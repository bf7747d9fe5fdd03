"""The template benchmark's two motions (benchmark page *template*, method page §5.5): the
main table's smooth paths stay inside the frame without a reflection (the velocity changes
by at most the pieces' acceleration per frame), the stress table's bouncing paths reflect."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def bench():
    spec = importlib.util.spec_from_file_location(
        "bench_template", ROOT / "benches" / "bench_template.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_smooth_paths_stay_inside_without_reflection(bench):
    high = bench.SIZE - bench.OBJECT
    for seed in range(40):
        path = bench.trajectory(50, seed, "smooth")
        rounded = np.rint(path)
        assert rounded.min() >= 0 and rounded.max() <= high
        speed = np.diff(path, axis=0)
        assert np.abs(speed).max() <= 3.0 + 1e-12
        # acceleration ≤ 0.15 px/frame² per axis (the clip to ±3 px/frame only lowers it)
        assert np.abs(np.diff(speed, axis=0)).max() <= 0.15 + 1e-12
    # the offset is drawn, not fixed: the starts spread over the frame
    starts = np.array([bench.trajectory(50, s, "smooth")[0] for s in range(40)])
    assert starts.std(axis=0).min() > 10


def test_bouncing_paths_reflect(bench):
    flips = 0
    for seed in range(40):
        speed = np.diff(bench.trajectory(50, seed, "bouncing"), axis=0)
        flips += int((np.abs(np.diff(speed, axis=0)) > 0.5).any())
    assert flips >= 10  # reversals (a velocity change of more than 0.15 px/frame²) occur
