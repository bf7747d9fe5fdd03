"""Plain-NumPy reference of the frame segmentation (method page *Tracking*, §3; [K93]): twin of the
Rust module ``segment`` and of ``kalmanfield.segment``, written for clarity (a breadth-first
flood fill per segment, then the moments pixel by pixel); meant for small frames."""

from __future__ import annotations

from collections import deque

import numpy as np
import pandas as pd

from ...tracking.segment import COLUMNS

_EDGE_STEPS = ((-1, 0), (1, 0), (0, -1), (0, 1))
_CORNER_STEPS = ((-1, -1), (-1, 1), (1, -1), (1, 1))


def segment(
    frame: np.ndarray, threshold: float, min_area: int = 1, connectivity: int = 8
) -> tuple[pd.DataFrame, np.ndarray]:
    """(segment table, int32 label image) with the definitions of ``kalmanfield.segment``:
    foreground v > threshold, weight w = v − threshold, centroid Σ w x / Σ w, amplitude the
    mean value, extent √(Σ w (x − x̄)² / Σ w), inclusive bbox, segments of area < min_area
    dropped, labels 1..n in raster order of the first pixel. No input checks."""
    values = np.asarray(frame, dtype=np.float64)
    components = connected_components(values > threshold, connectivity)
    kept = [pixels for pixels in components if len(pixels) >= min_area]
    labels = np.zeros(values.shape, dtype=np.int32)
    rows = []
    for label, pixels in enumerate(kept, start=1):
        ys, xs = np.array(pixels).T
        labels[ys, xs] = label
        rows.append(segment_row(values[ys, xs], xs, ys, threshold, label))
    table = pd.DataFrame(rows, columns=list(COLUMNS))
    int_columns = {"area", "bbox_x0", "bbox_y0", "bbox_x1", "bbox_y1", "label"}
    dtypes = {c: np.int64 if c in int_columns else np.float64 for c in COLUMNS}
    return table.astype(dtypes), labels


def connected_components(mask: np.ndarray, connectivity: int) -> list[list[tuple[int, int]]]:
    """The (row, column) pixels of each connected component of `mask`, components in raster
    order of their first pixel (the flood fill starts there)."""
    steps = _EDGE_STEPS + (_CORNER_STEPS if connectivity == 8 else ())
    height, width = mask.shape
    seen = np.zeros(mask.shape, dtype=bool)
    components = []
    for r in range(height):
        for c in range(width):
            if not mask[r, c] or seen[r, c]:
                continue
            seen[r, c] = True
            queue, pixels = deque([(r, c)]), []
            while queue:
                y, x = queue.popleft()
                pixels.append((y, x))
                for dy, dx in steps:
                    ny, nx = y + dy, x + dx
                    if 0 <= ny < height and 0 <= nx < width and mask[ny, nx] and not seen[ny, nx]:
                        seen[ny, nx] = True
                        queue.append((ny, nx))
            components.append(pixels)
    return components


def segment_row(
    v: np.ndarray, xs: np.ndarray, ys: np.ndarray, threshold: float, label: int
) -> tuple:
    """One table row (in ``COLUMNS`` order) from a segment's pixel values and coordinates."""
    w = v - threshold
    total = w.sum()
    cx, cy = np.sum(w * xs) / total, np.sum(w * ys) / total
    return (
        cx,
        cy,
        v.mean(),
        len(v),
        np.sqrt(np.sum(w * (xs - cx) ** 2) / total),
        np.sqrt(np.sum(w * (ys - cy) ** 2) / total),
        xs.min(),
        ys.min(),
        xs.max(),
        ys.max(),
        label,
    )
