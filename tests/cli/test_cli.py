"""Every command of the command line, end to end on real files: what it writes equals the
library's result, and bad files and arguments give a message and the documented exit code
(1 bad input, 2 bad command line, 3 missing optional dependency)."""

import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import kalmanfield as kf
from kalmanfield import io
from kalmanfield.cli import main, parser

pytest.importorskip("matplotlib")
pytest.importorskip("tifffile")
pytest.importorskip("imageio")
pytest.importorskip("zarr")

ROOT = Path(__file__).resolve().parents[2]


def run(capsys, *argv):
    """(exit code, stdout, stderr) of the command line, in this process."""
    try:
        code = main([*argv])
    except SystemExit as stop:  # argparse: --help, --version, usage errors
        code = stop.code
    out = capsys.readouterr()
    return code, out.out, out.err


def test_version_is_cargo_toml_s(capsys):
    cargo = re.search(r'^version = "([^"]+)"', (ROOT / "Cargo.toml").read_text(), re.M)
    done = subprocess.run(
        [sys.executable, "-m", "kalmanfield", "--version"], capture_output=True, text=True
    )
    assert done.returncode == 0
    assert done.stdout.strip() == f"kalmanfield {kf.__version__}"
    if kf.__version__ != "0+unknown":  # (a source tree that is not installed has no version)
        assert kf.__version__ == cargo.group(1)


def _commands(p, prefix=()):
    for action in p._actions:
        if hasattr(action, "choices") and isinstance(action.choices, dict):
            for name, sub in action.choices.items():
                yield (*prefix, name)
                yield from _commands(sub, (*prefix, name))


@pytest.mark.parametrize("command", list(_commands(parser())), ids=" ".join)
def test_every_command_has_help(capsys, command):
    code, out, _ = run(capsys, *command, "--help")
    assert code == 0 and out.startswith("usage: kalmanfield")


def test_no_command_is_a_usage_error(capsys):
    code, _, err = run(capsys)
    assert code == 2 and "COMMAND" in err


# -- simulate ------------------------------------------------------------------------------
def test_simulate_field_equals_sample(tmp_path, capsys):
    code, out, _ = run(
        capsys,
        "simulate",
        "field",
        "--shape",
        "40",
        "30",
        "--rho",
        "0.9",
        "0.7",
        "--order",
        "2",
        "1",
        "--seed",
        "4",
        "--out",
        str(tmp_path / "f.npy"),
    )
    assert code == 0 and "f.npy" in out
    expected = kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((40, 30), seed=4)
    assert np.array_equal(np.load(tmp_path / "f.npy"), expected)


def test_simulate_field_into_zarr_row_by_row(tmp_path, capsys):
    code, _, _ = run(
        capsys,
        "simulate",
        "field",
        "--shape",
        "300",
        "50",
        "--seed",
        "2",
        "--dtype",
        "float32",
        "--out",
        str(tmp_path / "f.zarr"),
        "--quiet",
    )
    assert code == 0
    expected = kf.ARFieldModel([0.9, 0.9], [2, 2]).sample((300, 50), seed=2, dtype=np.float32)
    assert np.array_equal(io.open_zarr(tmp_path / "f.zarr")[...], expected)


def test_simulate_sequence_with_a_model_file_and_noise(tmp_path, capsys):
    model = kf.ARFieldModel([0.95, 0.9, 0.8], [1, 2, 1], 2.0)
    io.write_model(tmp_path / "m.json", model)
    argv = [
        "simulate",
        "sequence",
        "--model",
        str(tmp_path / "m.json"),
        "--frames",
        "7",
        "--shape",
        "20",
        "16",
        "--seed",
        "3",
        "--quiet",
    ]
    assert run(capsys, *argv, "--out", str(tmp_path / "s.tif"))[0] == 0
    assert np.array_equal(io.read_stack(tmp_path / "s.tif"), model.sample((7, 20, 16), seed=3))
    assert run(capsys, *argv, "--noise-std", "0.5", "--out", str(tmp_path / "n.npy"))[0] == 0
    noise = np.load(tmp_path / "n.npy") - model.sample((7, 20, 16), seed=3)
    assert 0.35 < noise.std() < 0.65  # 2240 draws of N(0, 0.25): SE of the std ~0.008
    assert run(capsys, *argv, "--out", str(tmp_path / "frames"))[0] == 0
    assert len(list((tmp_path / "frames").glob("frame_*.png"))) == 7


def test_simulate_scene_equals_simulate_scene(tmp_path, capsys):
    argv = ["simulate", "scene", "--frames", "6", "--shape", "40", "48", "--targets", "2"]
    argv += ["--snr", "4", "--p-false", "0.5", "--seed", "5", "--quiet"]
    assert run(capsys, *argv, "--out", str(tmp_path / "s.npy"))[0] == 0
    scene = kf.simulate_scene((40, 48), 6, targets=2, snr=4.0, p_false=0.5, dt=0.1, seed=5)
    assert np.array_equal(np.load(tmp_path / "s.npy"), scene.frames)
    truth = pd.read_csv(tmp_path / "s.npy.truth.csv")
    assert list(truth.columns) == ["frame", "target", "x", "y", "vx", "vy"]
    assert np.allclose(truth[["x", "y"]], scene.truth[["x", "y"]])
    got, _, err = run(capsys, *argv, "--p-false", "2", "--out", str(tmp_path / "t.npy"))
    assert got == 1 and "--p-false" in err and not (tmp_path / "t.npy").exists()


@pytest.mark.parametrize(
    "argv, code, message",
    [
        (["--shape", "10"], 1, "--shape has 1"),
        (["--rho", "1.5", "0.9"], 1, "rho"),
        (["--rho", "0.9"], 1, "--rho has 1 values"),
        (["--out", "x.weird"], 1, "unknown suffix"),
        (["--shape", "0", "5"], 2, "positive integer"),
        (["--model", "missing.json"], 1, "no such model file"),
        (["--seed", "-1"], 2, "non-negative"),
    ],
)
def test_simulate_bad_arguments(tmp_path, capsys, monkeypatch, argv, code, message):
    monkeypatch.chdir(tmp_path)
    if "--out" not in argv:
        argv = [*argv, "--out", "x.npy"]
    got, _, err = run(capsys, "simulate", "field", *argv)
    assert got == code and message in err
    assert not (tmp_path / "x.npy").exists()


# -- identify ------------------------------------------------------------------------------
def test_identify_writes_the_model_and_the_plot(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    x = kf.ARFieldModel([0.9, 0.6], [2, 1], 3.0).sample((256, 256), seed=8, mean=10.0)
    io.write_image("field.tif", x.astype(np.float32))
    code, out, _ = run(capsys, "identify", "field.tif")
    assert code == 0 and "not rejected" in out
    record = json.loads(Path("field_model.json").read_text())
    assert record["order"] == [2, 1] and abs(record["identified"]["mean"] - 10) < 1
    assert Path("field_correlation.png").stat().st_size > 10_000
    assert io.read_model("field_model.json") == kf.identify(x.astype(np.float32)).model


def test_identify_a_colour_picture(tmp_path, capsys):
    x = kf.ARFieldModel([0.95, 0.95], [1, 1]).sample((128, 128), seed=1)
    rgb = np.stack([x, x + 0.1, x - 0.1], axis=-1)
    io.write_image(tmp_path / "c.png", rgb)
    code, _, _ = run(
        capsys,
        "identify",
        str(tmp_path / "c.png"),
        "--json",
        str(tmp_path / "m.json"),
        "--plot",
        str(tmp_path / "p.png"),
        "--quiet",
    )
    assert code == 0 and io.read_model(tmp_path / "m.json").ndim == 2


def test_identify_bad_files(tmp_path, capsys):
    assert run(capsys, "identify", str(tmp_path / "missing.tif"))[0] == 1
    (tmp_path / "bad.png").write_bytes(b"\x89PNG not really")
    code, _, err = run(capsys, "identify", str(tmp_path / "bad.png"))
    assert code == 1 and "bad.png" in err
    io.write_image(tmp_path / "flat.tif", np.ones((32, 32), np.float32))
    code, _, err = run(capsys, "identify", str(tmp_path / "flat.tif"))
    assert code == 1 and "error" in err


def test_a_missing_optional_dependency_exits_3(tmp_path, capsys, monkeypatch):
    io.write_image(tmp_path / "x.tif", np.ones((8, 8), np.float32))
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    code, _, err = run(capsys, "identify", str(tmp_path / "x.tif"))
    assert code == 3 and 'pip install "kalmanfield[demo]"' in err


# -- denoise -------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def noisy_field(tmp_path_factory):
    folder = tmp_path_factory.mktemp("denoise")
    model = kf.ARFieldModel([0.95, 0.95], [2, 2])
    x = model.sample((96, 128), seed=1)
    z = x + np.random.default_rng(2).normal(0, 0.5, x.shape)
    io.write_image(folder / "z.tif", z)
    return folder, model, x, z


def test_denoise_writes_the_estimate_and_its_error_map(noisy_field, tmp_path, capsys):
    folder, model, x, z = noisy_field
    code, out, _ = run(
        capsys, "denoise", str(folder / "z.tif"), "--out-dir", str(tmp_path), "--quiet"
    )
    assert code == 0
    estimate = io.read_image(tmp_path / "z_denoised.tif")
    error = io.read_image(tmp_path / "z_error_variance.tif")
    fitted, mean, noise_var = kf.model_from_noisy(z)
    row_filter = kf.ScalarRowFilter(fitted, noise_var, 128, smooth=True, mean=mean)
    assert np.array_equal(estimate, row_filter.filter(z))
    assert np.array_equal(error, row_filter.error_variance(96))
    # the predicted error variance is the error made, within the sampling error (the MSE of
    # one 96 × 128 image scatters by ~10 % around its expectation here)
    assert abs(np.mean((estimate - x) ** 2) / error.mean() - 1) < 0.35
    assert np.mean((estimate - x) ** 2) < 0.25 * np.mean((z - x) ** 2)


def test_denoise_with_a_model_file_and_a_picture(noisy_field, tmp_path, capsys):
    folder, model, x, z = noisy_field
    io.write_model(tmp_path / "m.json", kf.ARFieldModel(model.rho, model.order, 40.0))
    picture = np.clip(np.round(40 * z + 128), 0, 255).astype(np.uint8)
    io.write_image(tmp_path / "z.png", picture)
    code, _, _ = run(
        capsys,
        "denoise",
        str(tmp_path / "z.png"),
        "--model",
        str(tmp_path / "m.json"),
        "--sigma",
        "20",
        "--out-dir",
        str(tmp_path),
        "--quiet",
    )
    assert code == 0
    estimate = io.read_image(tmp_path / "z_denoised.png")
    assert estimate.dtype == np.uint8 and estimate.shape == z.shape
    assert (tmp_path / "z_error_variance.tif").is_file()  # values kept, not an 8-bit view
    truth = 40 * x + 128
    assert np.mean((estimate - truth) ** 2) < 0.3 * np.mean((picture - truth) ** 2)


def test_denoise_adaptive_has_no_error_map(noisy_field, tmp_path, capsys):
    folder, *_ = noisy_field
    code, out, _ = run(
        capsys,
        "denoise",
        str(folder / "z.tif"),
        "--method",
        "adaptive",
        "--out-dir",
        str(tmp_path),
        "--format",
        ".npy",
    )
    assert code == 0 and (tmp_path / "z_denoised.npy").is_file()
    assert not (tmp_path / "z_error_variance.npy").exists()


def test_denoise_bad_input(noisy_field, tmp_path, capsys):
    folder, *_ = noisy_field
    code, _, err = run(capsys, "denoise", str(folder / "z.tif"), "--sigma", "1", "--noise-var", "1")
    assert code == 2 and "not allowed with" in err
    assert run(capsys, "denoise", str(folder / "z.tif"), "--sigma", "-1")[0] == 2
    assert run(capsys, "denoise", str(tmp_path / "none.tif"))[0] == 1
    (tmp_path / "m.json").write_text('{"rho": [0.9, 0.9], "order": [9, 9]}')
    code, _, err = run(
        capsys,
        "denoise",
        str(folder / "z.tif"),
        "--model",
        str(tmp_path / "m.json"),
        "--out-dir",
        str(tmp_path),
    )
    assert code == 1 and "multiplicity" in err


# -- track ---------------------------------------------------------------------------------
def _moving_spots(n_frames=12, size=64):
    grid = np.arange(size)
    frames = np.zeros((n_frames, size, size))
    truth = []
    for t in range(n_frames):
        for k, (x0, y0, vx, vy) in enumerate([(10, 12, 2.0, 1.0), (50, 40, -1.5, 0.5)]):
            x, y = x0 + vx * t, y0 + vy * t
            frames[t] += 5 * np.outer(
                np.exp(-((grid - y) ** 2) / 2), np.exp(-((grid - x) ** 2) / 2)
            )
            truth.append((t, k, x, y))
    return frames, pd.DataFrame(truth, columns=["frame", "target", "x", "y"])


@pytest.mark.parametrize("container", ["stack.tif", "folder", "stack.gif", "stack.mp4"])
def test_track_follows_two_spots(tmp_path, capsys, container):
    if container.endswith(".mp4"):
        pytest.importorskip("imageio_ffmpeg")
    frames, truth = _moving_spots()
    io.write_stack(tmp_path / container, frames)
    code, out, _ = run(
        capsys,
        "track",
        str(tmp_path / container),
        "--threshold",
        "1.0" if container == "stack.tif" else "otsu",
        "--out-dir",
        str(tmp_path),
    )
    assert code == 0 and "12 frames" in out
    tracks = pd.read_csv(tmp_path / f"{Path(container).stem}_tracks.csv")
    assert tracks.particle.nunique() == 2
    for _, track in tracks.groupby("particle"):
        merged = track.merge(truth, on="frame", suffixes=("", "_true"))
        near = np.hypot(merged.x - merged.x_true, merged.y - merged.y_true) < 1.0
        assert near.groupby(merged.target).sum().max() >= 11  # one target all along
    assert (tmp_path / f"{Path(container).stem}_tracks.png").stat().st_size > 10_000


def test_track_bad_input(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    code, _, err = run(capsys, "track", str(tmp_path / "empty"))
    assert code == 1 and "no frame files" in err
    code, _, err = run(capsys, "track", str(tmp_path / "empty"), "--threshold", "high")
    assert code == 2 and "otsu" in err
    io.write_image(tmp_path / "flat.tif", np.zeros((16, 16), np.float32))
    code, _, err = run(capsys, "track", str(tmp_path / "flat.tif"), "--no-figure")
    assert code == 1 and "constant" in err


# -- experiment ----------------------------------------------------------------------------
def test_experiment_writes_the_table_and_the_plot(tmp_path, capsys):
    code, _, _ = run(
        capsys,
        "experiment",
        "type-confusion",
        "--runs",
        "30",
        "--n-frames",
        "8",
        "--seed",
        "5",
        "--out",
        str(tmp_path),
        "--quiet",
    )
    assert code == 0
    table = pd.read_csv(tmp_path / "type-confusion.csv")
    expected = kf.experiments.type_confusion(n_frames=8, runs=30, seed=5, progress=False).table
    pd.testing.assert_frame_equal(table, expected, check_dtype=False)
    assert (tmp_path / "type-confusion.png").stat().st_size > 10_000


def test_experiment_bad_arguments(capsys):
    assert run(capsys, "experiment", "k95")[0] == 2
    assert run(capsys, "experiment", "type-confusion", "--runs", "0")[0] == 2
