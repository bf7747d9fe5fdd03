"""kalmanfield.io: every format round-trips what it keeps (values and dtype, or the 8-bit
view), stacks stream frame by frame, and bad files are clear errors."""

import json
import sys

import numpy as np
import pytest

import kalmanfield as kf
from kalmanfield import io

pytest.importorskip("imageio")
pytest.importorskip("tifffile")
pytest.importorskip("zarr")

STACK = np.random.default_rng(0).normal(size=(5, 12, 10)).astype(np.float32)


@pytest.mark.parametrize("name", ["s.npy", "s.tif", "s.tiff", "s.zarr"])
def test_lossless_stacks_round_trip(tmp_path, name):
    io.write_stack(tmp_path / name, STACK)
    back = io.read_stack(tmp_path / name)
    assert back.dtype == STACK.dtype and np.array_equal(back, STACK)


@pytest.mark.parametrize("name", ["s.tif", "s.zarr"])
def test_stacks_are_written_from_an_iterable_frame_by_frame(tmp_path, name):
    io.write_stack(tmp_path / name, (frame for frame in STACK))
    assert np.array_equal(io.read_stack(tmp_path / name), STACK)
    frames = list(io.iter_frames(tmp_path / name))
    assert len(frames) == 5 and np.array_equal(frames[3], STACK[3])


def test_zarr_chunks_and_appends(tmp_path):
    array = io.write_zarr(tmp_path / "a.zarr", (f for f in STACK), chunks=(2, 12, 10))
    assert array.shape == (5, 12, 10) and array.chunks == (2, 12, 10)
    assert np.array_equal(io.open_zarr(tmp_path / "a.zarr")[4], STACK[4])


def test_pictures_are_8_bit_views(tmp_path):
    ramp = np.linspace(-3.0, 5.0, 120).reshape(12, 10)
    io.write_image(tmp_path / "r.png", ramp)
    back = io.read_image(tmp_path / "r.png")
    assert back.dtype == np.uint8 and back.min() == 0 and back.max() == 255
    assert np.all(np.diff(back.astype(int).ravel()) >= 0)  # monotone, like the ramp
    grey = np.arange(120, dtype=np.uint8).reshape(12, 10)
    io.write_image(tmp_path / "g.png", grey)
    assert np.array_equal(io.read_image(tmp_path / "g.png"), grey)  # uint8 as it is


def test_a_folder_of_frames_in_natural_order(tmp_path):
    for t in (10, 2, 1):
        io.write_image(tmp_path / f"f{t}.tif", np.full((4, 4), t, np.float32))
    (tmp_path / "notes.txt").write_text("not a frame")
    assert [f[0, 0] for f in io.iter_frames(tmp_path)] == [1, 2, 10]


def test_gif_and_grey(tmp_path):
    io.write_stack(tmp_path / "m.gif", STACK)
    colour = io.read_stack(tmp_path / "m.gif")
    assert colour.shape[:3] == STACK.shape
    grey = io.read_stack(tmp_path / "m.gif", grey=True)
    assert grey.shape == STACK.shape
    # the brightest pixel of the stack is the brightest of the GIF
    assert np.unravel_index(grey.argmax(), grey.shape) == np.unravel_index(
        STACK.argmax(), STACK.shape
    )


def test_video(tmp_path):
    pytest.importorskip("imageio_ffmpeg")
    moving = np.zeros((6, 32, 32))
    for t in range(6):
        moving[t, 10:14, 4 + 3 * t : 8 + 3 * t] = 1.0
    io.write_stack(tmp_path / "m.mp4", moving, fps=5)
    back = io.read_stack(tmp_path / "m.mp4", grey=True)
    assert back.shape == (6, 32, 32)
    assert abs(np.argmax(back[5].sum(axis=0)) - 20) <= 2  # the block moved to x ≈ 19–22


def test_model_json_round_trip(tmp_path):
    fit = kf.identify(kf.ARFieldModel([0.9, 0.7], [2, 1]).sample((128, 128), seed=1))
    io.write_model(tmp_path / "m.json", fit)
    record = json.loads((tmp_path / "m.json").read_text())
    assert record["format"] == "kalmanfield.model/1" and len(record["identified"]["fits"]) == 2
    assert io.read_model(tmp_path / "m.json") == fit.model


@pytest.mark.parametrize(
    "text, match",
    [
        ("not json", "not a JSON"),
        ('{"rho": [0.9]}', "'rho' and 'order'"),
        ('{"rho": [1.5], "order": [1]}', "rho"),
        ('{"rho": [0.5], "order": ["x"]}', "order"),
    ],
)
def test_bad_model_files(tmp_path, text, match):
    (tmp_path / "m.json").write_text(text)
    with pytest.raises(ValueError, match=match):
        io.read_model(tmp_path / "m.json")


def test_bad_files_are_clear_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="missing"):
        io.read_image(tmp_path / "missing.png")
    (tmp_path / "x.weird").write_text("")
    with pytest.raises(ValueError, match="unknown suffix"):
        io.read_image(tmp_path / "x.weird")
    with pytest.raises(ValueError, match="unknown suffix"):
        io.write_stack(tmp_path / "x.weird", STACK)
    (tmp_path / "bad.tif").write_bytes(b"garbage" * 10)
    with pytest.raises(ValueError, match="bad.tif"):
        io.read_stack(tmp_path / "bad.tif")
    (tmp_path / "bad.png").write_bytes(b"garbage" * 10)
    with pytest.raises(ValueError, match="bad.png"):
        io.read_image(tmp_path / "bad.png")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no frame files"):
        io.read_stack(tmp_path / "empty")
    io.write_image(tmp_path / "frames" / "a.tif", np.zeros((4, 4), np.float32))
    io.write_image(tmp_path / "frames" / "b.tif", np.zeros((5, 4), np.float32))
    with pytest.raises(ValueError, match="differ in shape"):
        io.read_stack(tmp_path / "frames")
    with pytest.raises(ValueError, match="image"):
        io.write_image(tmp_path / "x.png", np.zeros(5))
    with pytest.raises(ValueError, match="no frame"):
        io.write_zarr(tmp_path / "z.zarr", iter([]))


def test_a_missing_library_names_the_extra(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "tifffile", None)
    with pytest.raises(ImportError, match=r'pip install "kalmanfield\[io\]"'):
        io.write_image(tmp_path / "x.tif", np.zeros((4, 4)))
