"""The main job (python -m kalmanfield.demo) runs end to end and its filtering numbers are those of
method page *Row filters*, §2: every filter far below the noise, the smoothed O(W) filter near
the Wiener bound, the optimal filter's predicted error variance equal to its measured MSE."""

import subprocess
import sys

import pytest

from kalmanfield import demo


def test_demo_runs_and_writes_its_files(tmp_path):
    assert demo.main(["--out", str(tmp_path), "--size", "128", "--seed", "3"]) == 0
    for name in ("eight_point_2x2.png", "filtering.png", "tracks.csv", "tracks.png"):
        assert (tmp_path / name).stat().st_size > 0


@pytest.mark.parametrize("size", ["0", "-3", "4", "16", "x"])
def test_a_bad_size_is_a_usage_error_not_a_traceback(tmp_path, size, capsys):
    with pytest.raises(SystemExit) as stop:
        demo.main(["--out", str(tmp_path), "--size", size])
    assert stop.value.code == 2
    assert "--size" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing was written


def test_the_package_runs_as_a_module():
    run = subprocess.run(
        [sys.executable, "-m", "kalmanfield", "--help"], capture_output=True, text=True
    )
    assert run.returncode == 0 and "--size" in run.stdout


def test_the_smallest_size_runs(tmp_path):
    assert demo.main(["--out", str(tmp_path), "--size", str(demo.MIN_SIZE), "--seed", "0"]) == 0


def test_filtering_numbers_are_ordered_as_the_theory_says(tmp_path):
    mse = demo._filtering_demo(tmp_path, 256, seed=5)
    noisy = mse["noisy image"]
    optimal = mse["VectorRowFilter (optimal, causal)"]
    quasi = mse["ScalarRowFilter (O(W) per row, causal)"]
    smoothed = mse["ScalarRowFilter smooth=True"]
    bound = mse["Wiener bound (no estimator does better)"]
    predicted = mse["predicted (VectorRowFilter.error_variance)"]
    # one 256² realisation: its MSEs scatter around their expectations; the bounds are ~5 SD
    # of 10 seeds of this demo (2026-11-29), or 5 SE where one is known
    assert abs(noisy - 1) < 5 * (2 / 256**2) ** 0.5  # mean of 256² χ²₁ / 1
    assert abs(optimal / predicted - 1) < 0.15  # SD 0.029
    # the O(W) filter's own error map: within ~1 % of the optimal one's for (2,2), ρ = 0.9
    predicted_quasi = mse["predicted (ScalarRowFilter.error_variance)"]
    assert abs(predicted_quasi / predicted - 1) < 0.02  # 1.05 % (no sampling in it)
    assert abs(quasi / optimal - 1) < 0.01  # the same realisation: 1.0005, SD 0.0014
    assert smoothed < 0.57 * optimal  # the backward pass halves the error: 0.50, SD 0.013
    assert abs(smoothed / bound - 1) < 0.15  # SD 0.031
    assert mse["denoise (model and noise estimated)"] < 1.15 * smoothed  # 1.026, SD 0.025


def test_tracking_demo_follows_the_targets(tmp_path):
    # 8 targets × 60 frames; 94–100 % of the true positions had a track point within 2 px on
    # seeds 0–5 (2026-11-29)
    assert demo._tracking_demo(tmp_path, seed=3) > 0.9
    assert (tmp_path / "tracks.csv").stat().st_size > 0
