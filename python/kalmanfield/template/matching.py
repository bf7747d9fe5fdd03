"""Correlation search of a template in a frame: the correlation-extreme link of the
search-recurrent tracker (method page *Template tracker*, §5.2); the Rust kernel
``_core.match_template``, its twin :func:`kalmanfield.reference.template.match_template`."""

from __future__ import annotations

from typing import Literal, overload

import numpy as np
import numpy.typing as npt

from .. import _core
from ._inputs import frame_array, method_name, template_array, window_tuple

Match = tuple[float, float, float]


@overload
def match_template(
    frame: npt.ArrayLike,
    template: npt.ArrayLike,
    *,
    window: tuple[int, int, int, int] | None = ...,
    method: str = ...,
    subpixel: bool = ...,
    return_surface: Literal[False] = ...,
) -> Match: ...
@overload
def match_template(
    frame: npt.ArrayLike,
    template: npt.ArrayLike,
    *,
    window: tuple[int, int, int, int] | None = ...,
    method: str = ...,
    subpixel: bool = ...,
    return_surface: Literal[True],
) -> tuple[float, float, float, np.ndarray]: ...
def match_template(
    frame: npt.ArrayLike,
    template: npt.ArrayLike,
    *,
    window: tuple[int, int, int, int] | None = None,
    method: str = "ncc",
    subpixel: bool = True,
    return_surface: bool = False,
) -> Match | tuple[float, float, float, np.ndarray]:
    """Where `template` best matches `frame`: the peak of the correlation surface.

    Parameters
    ----------
    frame : 2-D array-like
        The image searched. The dtypes uint8, uint16, float32 and float64 are searched as
        they are (no copy when C-contiguous); bool becomes uint8, other real dtypes float64.
        NaN pixels are missing: every position whose template footprint covers one scores
        NaN and is never the peak.
    template : 2-D array-like
        The fragment searched for. A NumPy array must have the frame's dtype; a list is
        taken in the frame's dtype when its values fit exactly.
    window : (x0, y0, x1, y1), optional
        Search only ``frame[y0:y1, x0:x1]`` (x1, y1 exclusive): the whole template lies in it.
        Default: the whole frame.
    method : {"ncc", "correlation"}
        ``"ncc"``: zero-mean normalised cross-correlation in [−1, 1] (OpenCV's
        ``TM_CCOEFF_NORMED``, scikit-image's ``match_template``); a flat window scores 0.
        ``"correlation"``: the plain sum Σ frame · template of the source.
    subpixel : bool
        Refine the integer peak by a Newton step on its 3 × 3 neighbourhood (exact for a
        quadratic peak).
    return_surface : bool
        Also return the surface: shape (y1 − y0 − h + 1, x1 − x0 − w + 1), entry [r, c] the
        score of the template at top-left (x0 + c, y0 + r).

    Returns
    -------
    x, y : float
        Column and row of the template's **top-left** pixel at the peak (OpenCV's
        ``minMaxLoc`` location); its centre is (x + (w − 1)/2, y + (h − 1)/2).
    score : float
        The surface's value at the integer peak.
    surface : ndarray
        Only with ``return_surface=True``: the scores of every position (see
        `return_surface`), NaN where the footprint covers a missing pixel.

    Raises
    ------
    TypeError
        Non-real pixels; a template array whose dtype differs from the frame's.
    ValueError
        Not 2-D or empty; the window not inside the frame or smaller than the template; an
        infinite pixel; a constant template with ``"ncc"`` (undefined); every position
        covering a NaN pixel.

    Notes
    -----
    Direct sums for small templates, FFT correlation where it costs less; running window
    sums for the normalisation. See the method page *Template tracker*, §5.2–5.3.

    Examples
    --------
    >>> import numpy as np
    >>> from kalmanfield import match_template
    >>> frame = np.random.default_rng(0).standard_normal((64, 64))
    >>> x, y, score = match_template(frame, frame[20:30, 5:17])
    >>> (round(x), round(y)), round(score, 6)
    ((5, 20), 1.0)
    """
    image = frame_array(frame)
    kernel = template_array(template, image.dtype)
    region = None if window is None else window_tuple(window)
    x, y, score, surface = _core.match_template(
        image, kernel, region, method_name(method), bool(subpixel), bool(return_surface)
    )
    if return_surface:
        assert surface is not None
        return x, y, score, surface
    return x, y, score
