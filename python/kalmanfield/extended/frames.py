"""Frame preparation for the detector: checks, missing pixels, smoothing, threshold,
segmentation into the (m, 8) measurement table of stage 2."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .. import _core
from .._validation import check_real_dtype
from ..denoising import estimate_sigma

__all__ = ["FrameCheck", "box_smooth", "segment_frame"]


@dataclass
class FrameCheck:
    """Shape and dtype of the first frame, which every later frame must share."""

    shape: tuple[int, int] | None = None
    dtype: str | None = None

    def frame(self, frame: npt.ArrayLike, index: int) -> np.ndarray:
        raw = np.asarray(
            np.ma.filled(frame, np.nan) if isinstance(frame, np.ma.MaskedArray) else frame
        )
        check_real_dtype(raw, f"frame {index}")
        if raw.ndim != 2:
            raise ValueError(f"frame {index} must be 2-D, got {raw.ndim} dimensions")
        if self.shape is None:
            self.shape, self.dtype = (int(raw.shape[0]), int(raw.shape[1])), raw.dtype.str
        elif raw.shape != self.shape or raw.dtype.str != self.dtype:
            raise ValueError(
                f"frame {index} has shape {raw.shape} and dtype {raw.dtype}, the first frame "
                f"{self.shape} and {np.dtype(self.dtype)}: all frames must match"
            )
        if min(raw.shape) < 2:
            raise ValueError(f"frames must be at least 2 × 2, got {raw.shape}")
        out = np.asarray(raw, dtype=np.float64)  # read only: copied below if changed
        if np.isfinite(out.sum()):  # all finite (one reduction; an overflow checks below)
            return out
        if np.isinf(out).any():
            raise ValueError(f"frame {index} holds an infinite value")
        missing = np.isnan(out)
        if not missing.any():
            return out  # finite values whose sum overflowed
        if missing.all():
            raise ValueError(f"frame {index} has no finite pixel")
        out = out.copy()
        out[missing] = np.median(out[~missing])  # missing: never foreground on its own
        return out


def box_smooth(image: np.ndarray, width: int, out: np.ndarray | None = None) -> np.ndarray:
    """Mean over a width × width box centred on each pixel (edges repeated), into `out` when
    given (a float64 buffer of the image's shape, reused frame after frame); Rust kernel,
    twin :func:`kalmanfield.reference.extended.box_smooth`."""
    if width == 1:
        return image
    return _core.extended_smooth(np.ascontiguousarray(image, dtype=np.float64), width, out)


def background_level(smoothed: np.ndarray) -> float:
    """Median of the smoothed frame: of every 4th row and column beyond 256² pixels (Rust,
    twin :func:`kalmanfield.reference.extended.background_level`)."""
    return _core.extended_level(np.ascontiguousarray(smoothed, dtype=np.float64))


def box_mean(image: np.ndarray, width: int) -> np.ndarray:
    """Mean over a width × width box centred on each pixel (edges repeated), by cumulative
    sums: O(1) per pixel whatever the width (the local background level)."""
    lo = width // 2
    padded = np.pad(image, ((lo + 1, width - 1 - lo), (lo + 1, width - 1 - lo)), mode="edge")
    padded[0, :] = 0.0
    padded[:, 0] = 0.0
    c = padded.cumsum(axis=0).cumsum(axis=1)
    h, w = image.shape
    total = c[width:, width:] - c[:h, width:] - c[width:, :w] + c[:h, :w]
    return total / (width * width)


def noise_level(image: np.ndarray) -> float:
    """σ of the white noise of a frame (:func:`kalmanfield.estimate_sigma`)."""
    return float(estimate_sigma(image))


def segment_frame(
    smoothed: np.ndarray, threshold: float, min_area: int, connectivity: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(measurements (m, 8): x, y, amplitude, area, bbox x0, y0, x1, y1; labels of the
    segments; label image) of a smoothed frame."""
    columns, labels = _core.segment(smoothed, float(threshold), min_area, connectivity)
    table = (
        np.column_stack(
            [
                columns["x"],
                columns["y"],
                columns["amplitude"],
                columns["area"],
                columns["bbox_x0"],
                columns["bbox_y0"],
                columns["bbox_x1"],
                columns["bbox_y1"],
            ]
        )
        .astype(np.float64)
        .reshape(-1, 8)
    )
    return table, np.asarray(columns["label"]), labels
