"""Plain-NumPy twin of the correlation search (``rust/src/template``): every window's score
computed from its definition (means and variances of the window itself), for small frames.

Same conventions as :func:`kalmanfield.match_template`: positions are the template's top-left
(x = column, y = row); a window (x0, y0, x1, y1) is ``frame[y0:y1, x0:x1]``; NaN pixels make
every position covering them NaN; a flat window scores 0 under NCC.
"""

from __future__ import annotations

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

#: a window whose n·variance is at most this fraction of Σ (pixel − shift)² is flat (NCC 0)
FLAT_WINDOW = 1e-12

#: pixels per axis of the subsample whose mean is the shift
SHIFT_SAMPLES = 64


def shift(region: np.ndarray, integer: bool) -> float:
    """The mean of the observed pixels at rows k·⌊rows/64⌋ and columns l·⌊cols/64⌋ (k, l <
    64), rounded half away from zero for integer pixels; 0 if none is observed."""
    rows, cols = region.shape
    sub = region[:: max(rows // SHIFT_SAMPLES, 1), :: max(cols // SHIFT_SAMPLES, 1)]
    sub = sub[:SHIFT_SAMPLES, :SHIFT_SAMPLES].astype(np.float64)
    finite = sub[np.isfinite(sub)]
    mean = float(finite.mean()) if finite.size else 0.0
    return float(np.sign(mean) * np.floor(abs(mean) + 0.5)) if integer else mean


def surface(
    frame: np.ndarray,
    template: np.ndarray,
    window: tuple[int, int, int, int] | None = None,
    method: str = "ncc",
) -> np.ndarray:
    """Score of every template position in the window (entry [r, c]: top-left (x0 + c,
    y0 + r)). NCC: Σ(w − w̄)(t − t̄) / √(Σ(w − w̄)² Σ(t − t̄)²), clamped to [−1, 1]; 0 for a flat
    window; ``"correlation"``: Σ w·t."""
    x0, y0, x1, y1 = window if window is not None else (0, 0, frame.shape[1], frame.shape[0])
    region = np.asarray(frame[y0:y1, x0:x1], dtype=np.float64)
    t = np.asarray(template, dtype=np.float64)
    windows = sliding_window_view(region, t.shape)
    if method == "correlation":
        return np.einsum("yxij,ij->yx", windows, t)
    c = shift(np.asarray(frame[y0:y1, x0:x1]), np.asarray(frame).dtype.kind in "ui")
    mean = windows.mean(axis=(2, 3), keepdims=True)
    centred = windows - mean
    spread = (centred**2).sum(axis=(2, 3))
    t_centred = t - t.mean()
    num = np.einsum("yxij,ij->yx", centred, t_centred)
    with np.errstate(invalid="ignore", divide="ignore"):
        score = np.clip(num / np.sqrt(spread * (t_centred**2).sum()), -1.0, 1.0)
    flat = spread <= FLAT_WINDOW * ((windows - c) ** 2).sum(axis=(2, 3))
    score[flat] = 0.0
    score[np.isnan(windows).any(axis=(2, 3))] = np.nan
    return score


def refine_peak(s: np.ndarray, ix: int, iy: int) -> tuple[float, float]:
    """(dx, dy): a Newton step on the 3 × 3 neighbourhood (central differences) when the
    Hessian is negative definite, both corners-and-edges exist and the step stays in [−1, 1]²;
    otherwise one parabola per axis (−g/c when the curvature c < 0), an axis without both
    neighbours (border or NaN) unrefined."""
    rows, cols = s.shape

    def at(dx: int, dy: int) -> float | None:
        x, y = ix + dx, iy + dy
        if 0 <= x < cols and 0 <= y < rows and not np.isnan(s[y, x]):
            return float(s[y, x])
        return None

    f0 = float(s[iy, ix])

    def axis(minus: float | None, plus: float | None) -> tuple[float, float] | None:
        if minus is None or plus is None:
            return None
        return (plus - minus) / 2.0, plus - 2.0 * f0 + minus

    ax, ay = axis(at(-1, 0), at(1, 0)), axis(at(0, -1), at(0, 1))
    corners = [at(1, 1), at(1, -1), at(-1, 1), at(-1, -1)]
    if ax is not None and ay is not None and None not in corners:
        pp, pm, mp, mm = (float(v) for v in corners)  # type: ignore[arg-type]
        hxy = (pp - pm - mp + mm) / 4.0
        (gx, hxx), (gy, hyy) = ax, ay
        det = hxx * hyy - hxy * hxy
        if hxx < 0 and det > 0:
            step = -np.linalg.solve([[hxx, hxy], [hxy, hyy]], [gx, gy])
            if np.all(np.abs(step) <= 1.0):
                return float(step[0]), float(step[1])

    def parabola(a: tuple[float, float] | None) -> float:
        if a is None or a[1] >= 0:
            return 0.0
        return float(np.clip(-a[0] / a[1], -1.0, 1.0))

    return parabola(ax), parabola(ay)


def match_template(
    frame: np.ndarray,
    template: np.ndarray,
    window: tuple[int, int, int, int] | None = None,
    method: str = "ncc",
    subpixel: bool = True,
) -> tuple[float, float, float, np.ndarray]:
    """(x, y, score, surface): the first (raster order) highest non-NaN score, refined."""
    s = surface(frame, template, window, method)
    x0, y0 = (window[0], window[1]) if window is not None else (0, 0)
    flat_index = int(np.nanargmax(s))
    iy, ix = divmod(flat_index, s.shape[1])
    dx, dy = refine_peak(s, ix, iy) if subpixel else (0.0, 0.0)
    return x0 + ix + dx, y0 + iy + dy, float(s[iy, ix]), s
