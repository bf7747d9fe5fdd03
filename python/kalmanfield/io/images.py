"""Images and stacks of frames in files: ``.npy``, TIFF (tifffile), PNG/JPEG/GIF and video
(imageio; video through its ffmpeg plugin), zarr stores and folders of frames."""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Union

import numpy as np
import numpy.typing as npt

from ._optional import optional
from .zarr_store import ZARR_SUFFIXES, open_zarr, write_zarr

PathLike = Union[str, "Path"]

#: single pictures read and written by imageio
PICTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".webp")
TIFF_SUFFIXES = (".tif", ".tiff")
#: animations and videos: imageio (videos through the ffmpeg plugin, imageio-ffmpeg)
MOVIE_SUFFIXES = (".gif", ".mp4", ".avi", ".mov", ".mkv", ".webm", ".m4v")
#: what a folder of frames may hold
FRAME_SUFFIXES = (".npy", *TIFF_SUFFIXES, *PICTURE_SUFFIXES)

_DECODE_ERRORS = (OSError, ValueError, RuntimeError, EOFError, KeyError, IndexError)


def _existing(path: PathLike) -> Path:
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"no such file or folder: {p}")
    return p


def _suffix(path: Path) -> str:
    return path.suffix.lower()


def _unsupported(path: Path, what: str) -> ValueError:
    kinds = ", ".join([".npy", *TIFF_SUFFIXES, *PICTURE_SUFFIXES, *MOVIE_SUFFIXES, *ZARR_SUFFIXES])
    return ValueError(f"cannot read or write {path} as {what}: unknown suffix (known: {kinds})")


def _decoded(path: Path, read: Any) -> np.ndarray:
    """`read()` with the decoders' errors turned into a ValueError naming the file."""
    try:
        return np.asarray(read())
    except _DECODE_ERRORS as err:
        if isinstance(err, FileNotFoundError):
            raise
        raise ValueError(f"cannot read {path}: {type(err).__name__}: {err}") from err


def read_image(path: PathLike) -> np.ndarray:
    """Read one image from a file.

    Parameters
    ----------
    path : str or pathlib.Path
        A ``.npy`` file, a TIFF (its first page), or a picture imageio reads (PNG, JPEG,
        BMP, WebP).

    Returns
    -------
    numpy.ndarray
        The image as stored: (H, W), or (H, W, 3|4) for colour, in the file's dtype.

    Raises
    ------
    FileNotFoundError
        No such file.
    ValueError
        An unknown suffix, or a file that does not decode (corrupt, or not an image).
    ImportError
        The library the format needs is not installed (the message names the extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/x.npy"
    >>> io.write_image(path, np.eye(3))
    >>> io.read_image(path).shape
    (3, 3)
    """
    p = _existing(path)
    suffix = _suffix(p)
    if suffix == ".npy":
        image = _decoded(p, lambda: np.load(p, allow_pickle=False))
    elif suffix in TIFF_SUFFIXES:
        tifffile = optional("tifffile", "reading TIFF")
        image = _decoded(p, lambda: tifffile.imread(p, key=0))
    elif suffix in PICTURE_SUFFIXES:
        iio = optional("imageio.v3", f"reading {suffix}")
        image = _decoded(p, lambda: iio.imread(p))
    else:
        raise _unsupported(p, "an image")
    if image.ndim not in (2, 3) or image.size == 0:
        raise ValueError(f"{p} holds an array of shape {image.shape}, not an image")
    return image


def to_uint8(data: np.ndarray, low: float | None = None, high: float | None = None) -> np.ndarray:
    """`data` on 0…255 for viewing: uint8 as it is; anything else scaled linearly from
    [low, high] (default its finite min and max), NaN → 0."""
    if data.dtype == np.uint8:
        return data
    values = np.asarray(data, dtype=np.float64)
    finite = values[np.isfinite(values)]
    if low is None:
        low = float(finite.min()) if finite.size else 0.0
    if high is None:
        high = float(finite.max()) if finite.size else 1.0
    span = high - low if high > low else 1.0
    scaled = np.clip((np.nan_to_num(values, nan=low) - low) / span, 0.0, 1.0)
    return np.round(255.0 * scaled).astype(np.uint8)


def write_image(path: PathLike, image: npt.ArrayLike) -> None:
    """Write one image to a file (its folder is made if missing).

    Parameters
    ----------
    path : str or pathlib.Path
        ``.npy`` and TIFF keep the values and the dtype; PNG, JPEG, BMP and WebP are for
        viewing: uint8 (and uint16 PNG) are written as they are, anything else is scaled
        from its [min, max] onto 8 bits.
    image : array_like
        A 2-D image, or (H, W, 3|4) colour.

    Raises
    ------
    ValueError
        An unknown suffix, or an array that is not an image.
    ImportError
        The library the format needs is not installed (the message names the extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/ramp.png"
    >>> io.write_image(path, np.linspace(0, 1, 64).reshape(8, 8))
    >>> io.read_image(path).dtype
    dtype('uint8')
    """
    p = Path(path)
    data = np.asarray(image)
    if data.ndim not in (2, 3) or data.size == 0:
        raise ValueError(f"an image must be 2-D or (H, W, channels), got shape {data.shape}")
    suffix = _suffix(p)
    if suffix not in (".npy", *TIFF_SUFFIXES, *PICTURE_SUFFIXES):
        raise _unsupported(p, "an image")
    p.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".npy":
        np.save(p, data, allow_pickle=False)
    elif suffix in TIFF_SUFFIXES:
        optional("tifffile", "writing TIFF").imwrite(p, data)
    else:
        iio = optional("imageio.v3", f"writing {suffix}")
        keep = data.dtype == np.uint8 or (data.dtype == np.uint16 and suffix == ".png")
        iio.imwrite(p, data if keep else to_uint8(data))


def _natural_key(path: Path) -> list[Any]:
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", path.name)]


def _folder_frames(folder: Path) -> Iterator[np.ndarray]:
    files = sorted(
        (f for f in folder.iterdir() if f.is_file() and _suffix(f) in FRAME_SUFFIXES),
        key=_natural_key,
    )
    if not files:
        raise ValueError(f"the folder {folder} holds no frame files ({', '.join(FRAME_SUFFIXES)})")
    for file in files:
        yield read_image(file)


def _tiff_frames(path: Path) -> Iterator[np.ndarray]:
    tifffile = optional("tifffile", "reading TIFF")
    try:
        tif = tifffile.TiffFile(path)
    except _DECODE_ERRORS as err:
        raise ValueError(f"cannot read {path}: {type(err).__name__}: {err}") from err
    with tif:
        if len(tif.pages) == 1:  # one image, grey or colour
            yield _decoded(path, tif.series[0].asarray)
            return
        for page in tif.pages:
            yield _decoded(path, page.asarray)


def _movie_frames(path: Path) -> Iterator[np.ndarray]:
    iio = optional("imageio.v3", f"reading {_suffix(path)}")
    if _suffix(path) != ".gif":
        optional_video()
    try:
        for frame in iio.imiter(path):
            yield np.asarray(frame)
    except _DECODE_ERRORS as err:
        raise ValueError(f"cannot read {path}: {type(err).__name__}: {err}") from err


def optional_video() -> None:
    """ImportError unless imageio can read and write video (its ffmpeg plugin)."""
    optional("imageio_ffmpeg", "video files (imageio's ffmpeg plugin)")


def _grey(frame: np.ndarray) -> np.ndarray:
    if frame.ndim == 3 and frame.shape[-1] in (3, 4):
        return frame[..., :3].mean(axis=-1)
    return frame


def iter_frames(path: PathLike, *, grey: bool = False) -> Iterator[np.ndarray]:
    """The frames of a stack, one at a time (a stack larger than memory streams).

    Parameters
    ----------
    path : str or pathlib.Path
        A folder of frame files (``.npy``, TIFF or pictures, in natural order of their
        names: ``f2`` before ``f10``), a TIFF stack, a 3-D ``.npy`` (memory-mapped), a zarr
        store (``.zarr``), a GIF or a video (``.mp4``, ``.avi``, ``.mov``, ``.mkv``,
        ``.webm``; needs imageio-ffmpeg). A single image is a stack of one frame.
    grey : bool, default False
        Average the colour channels (the first three of a trailing axis of 3 or 4) into
        one intensity frame (float64).

    Yields
    ------
    numpy.ndarray
        Each frame: (H, W), or (H, W, 3|4) colour unless `grey`.

    Raises
    ------
    FileNotFoundError
        No such file or folder.
    ValueError
        An unknown suffix, a folder without frame files, a file that does not decode.
    ImportError
        The library the format needs is not installed (the message names the extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/stack.npy"
    >>> io.write_stack(path, np.zeros((5, 4, 4)))
    >>> [frame.shape for frame in io.iter_frames(path)][:2]
    [(4, 4), (4, 4)]
    """
    p = _existing(path)
    suffix = _suffix(p)
    if p.is_dir() and suffix not in ZARR_SUFFIXES:
        frames: Iterable[np.ndarray] = _folder_frames(p)
    elif suffix in TIFF_SUFFIXES:
        frames = _tiff_frames(p)
    elif suffix in MOVIE_SUFFIXES:
        frames = _movie_frames(p)
    elif suffix in ZARR_SUFFIXES:
        frames = _array_frames(p, open_zarr(p))
    elif suffix == ".npy":
        frames = _array_frames(p, _decoded(p, lambda: np.load(p, mmap_mode="r")))
    elif suffix in PICTURE_SUFFIXES:
        frames = iter([read_image(p)])
    else:
        raise _unsupported(p, "a stack of frames")
    for frame in frames:
        yield _grey(frame) if grey else frame


def _array_frames(path: Path, array: Any) -> Iterator[np.ndarray]:
    if array.ndim == 2:
        yield np.asarray(array)
    elif array.ndim in (3, 4):
        for t in range(array.shape[0]):
            yield np.asarray(array[t])
    else:
        raise ValueError(f"{path} holds an array of shape {array.shape}, not frames")


def read_stack(path: PathLike, *, grey: bool = False) -> np.ndarray:
    """Read a stack of frames into memory.

    Parameters
    ----------
    path : str or pathlib.Path
        Anything :func:`iter_frames` reads.
    grey : bool, default False
        Average colour channels into one intensity frame.

    Returns
    -------
    numpy.ndarray
        (F, H, W), or (F, H, W, 3|4) colour unless `grey`.

    Raises
    ------
    FileNotFoundError
        No such file or folder.
    ValueError
        An unknown suffix, a file that does not decode, frames of different shapes.
    ImportError
        The library the format needs is not installed (the message names the extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/stack.tif"
    >>> io.write_stack(path, np.zeros((5, 4, 6), dtype=np.float32))
    >>> io.read_stack(path).shape
    (5, 4, 6)
    """
    frames = list(iter_frames(path, grey=grey))
    shapes = {frame.shape for frame in frames}
    if len(shapes) > 1:
        raise ValueError(f"the frames of {path} differ in shape: {sorted(shapes)}")
    return np.stack(frames)


def write_stack(path: PathLike, frames: npt.ArrayLike | Iterable[np.ndarray], *, fps: float = 10.0):
    """Write a stack of frames (its folder is made if missing).

    Parameters
    ----------
    path : str or pathlib.Path
        ``.npy``, a TIFF stack and a zarr store (``.zarr``) keep the values; a GIF or a
        video (``.mp4``…; needs imageio-ffmpeg) is for viewing, all frames scaled from the
        stack's [min, max] onto 8 bits; a path without a suffix is a folder of PNG frames
        (``frame_00000.png``…, the same 8-bit scale).
    frames : array_like or iterable of arrays
        (F, H, W) or (F, H, W, 3|4). TIFF and zarr also take an iterable of frames and write
        them one at a time (a stack larger than memory streams).
    fps : float, default 10.0
        Frames per second of a GIF or a video.

    Raises
    ------
    ValueError
        An unknown suffix, or frames that are not a stack.
    ImportError
        The library the format needs is not installed (the message names the extra).

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from kalmanfield import io
    >>> path = tempfile.mkdtemp() + "/stack.zarr"
    >>> io.write_stack(path, np.ones((3, 8, 8)))
    >>> io.read_stack(path).shape
    (3, 8, 8)
    """
    p = Path(path)
    suffix = _suffix(p)
    streaming = not isinstance(frames, np.ndarray) and not hasattr(frames, "__array__")
    if suffix in ZARR_SUFFIXES:
        write_zarr(p, frames)
        return
    if suffix in TIFF_SUFFIXES:
        _write_tiff(p, frames if streaming else _stack(frames))  # type: ignore[arg-type]
        return
    stack = _stack(np.stack(list(frames)) if streaming else frames)  # type: ignore[arg-type]
    p.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".npy":
        np.save(p, stack, allow_pickle=False)
    elif suffix in MOVIE_SUFFIXES:
        iio = optional("imageio.v3", f"writing {suffix}")
        low, high = _finite_range(stack)
        movie = np.stack([to_uint8(frame, low, high) for frame in stack])
        if suffix == ".gif":
            iio.imwrite(p, movie, duration=1000.0 / fps, loop=0)
        else:
            optional_video()
            iio.imwrite(p, movie, fps=fps, plugin="FFMPEG", macro_block_size=1)
    elif suffix == "":
        p.mkdir(parents=True, exist_ok=True)
        low, high = _finite_range(stack)
        for t, frame in enumerate(stack):
            write_image(p / f"frame_{t:05d}.png", to_uint8(frame, low, high))
    else:
        raise _unsupported(p, "a stack of frames")


def _stack(frames: Any) -> np.ndarray:
    stack = np.asarray(frames)
    if stack.ndim not in (3, 4) or stack.size == 0:
        raise ValueError(f"a stack must be (F, H, W) or (F, H, W, channels), got {stack.shape}")
    return stack


def _finite_range(stack: np.ndarray) -> tuple[float, float]:
    finite = stack[np.isfinite(stack)] if stack.dtype.kind == "f" else stack.ravel()
    return (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)


def _write_tiff(path: Path, frames: Iterable[np.ndarray]) -> None:
    tifffile = optional("tifffile", "writing TIFF")
    path.parent.mkdir(parents=True, exist_ok=True)
    written = 0
    with tifffile.TiffWriter(path, bigtiff=True) as tif:
        for frame in frames:
            frame = np.asarray(frame)
            if frame.ndim not in (2, 3):
                raise ValueError(f"a frame must be 2-D (or with channels), got {frame.shape}")
            tif.write(frame, contiguous=True)
            written += 1
    if not written:
        raise ValueError("no frame to write")
