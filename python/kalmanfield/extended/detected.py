"""The result type of :func:`kalmanfield.detect_moving_objects`."""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["DetectedObject"]


class DetectedObject:
    """One moving object found by :func:`kalmanfield.detect_moving_objects`.

    Parameters
    ----------
    track : pandas.DataFrame
        Columns ``frame``, ``x``, ``y``, ``vx``, ``vy``: the object centre (area-weighted
        mean of its fragments' filtered centroids) and the group velocity, per frame where the
        object was seen.
    fragments : pandas.DataFrame
        Columns ``frame``, ``fragment`` (the segment sequence's id), ``x``, ``y``,
        ``amplitude``, ``area``: the segments the object is made of.
    pixels : dict of int to numpy.ndarray
        Per frame, the flat indices (row-major) of the object's pixels.
    shape : tuple of int
        The frame shape (H, W).
    score : float
        The ranking score (see Notes).
    id : int, default -1
        The object's id in the detector (stage-2 group, or stage-1 track).

    Notes
    -----
    ``score`` is the path length Σ ``|v|`` τ (pixels) travelled over the frames in which the object
    was detected (it had at least one fragment sequence longer than ν + 1 moving with the
    group), capped by the net displacement between its first and last detected centres: an
    object seen longer and moving faster ranks higher, moving background being assumed slower
    than the object (the source's Remark 1); a still object whose centre jitters (texture,
    merging clutter) or a short-lived one gains no score from its noisy velocity.
    Method page :doc:`/methods/extended_objects`, §3.4.

    Examples
    --------
    >>> import pandas as pd
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> track = pd.DataFrame({"frame": [0, 1], "x": [1.0, 2.0], "y": [1.0, 1.0],
    ...                       "vx": [1.0, 1.0], "vy": [0.0, 0.0]})
    >>> obj = kf.DetectedObject(track, pd.DataFrame(), {1: np.array([5, 6])}, (4, 4), 2.0)
    >>> int(obj.mask(1).sum()), obj.frames.tolist()
    (2, [0, 1])
    """

    def __init__(
        self,
        track: pd.DataFrame,
        fragments: pd.DataFrame,
        pixels: dict[int, np.ndarray],
        shape: tuple[int, int],
        score: float,
        id: int = -1,
    ) -> None:
        self.id = int(id)
        self.track = track
        self.fragments = fragments
        self._pixels = pixels
        self._shape = shape
        self.score = float(score)

    @property
    def frames(self) -> np.ndarray:
        """The frame numbers in which the object was detected."""
        return self.track["frame"].to_numpy()

    @property
    def velocity(self) -> np.ndarray:
        """(vx, vy) of the last detected frame, pixels per time unit."""
        if self.track.empty:
            return np.full(2, np.nan)
        return self.track[["vx", "vy"]].to_numpy()[-1].copy()

    def mask(self, frame_index: int) -> np.ndarray:
        """Return the bool image of the object in one frame.

        Parameters
        ----------
        frame_index : int
            The frame number.

        Returns
        -------
        numpy.ndarray
            (H, W) bool: the union of the object's segments, all False where it was not
            detected.

        Raises
        ------
        TypeError
            A non-integer `frame_index`.
        """
        if isinstance(frame_index, bool) or not isinstance(frame_index, (int, np.integer)):
            raise TypeError(f"frame_index must be an integer, got {type(frame_index).__name__}")
        out = np.zeros(self._shape[0] * self._shape[1], dtype=bool)
        out[self._pixels.get(int(frame_index), np.zeros(0, np.int64))] = True
        return out.reshape(self._shape)

    def __repr__(self) -> str:
        f = self.frames
        span = f"frames {f[0]}–{f[-1]}" if len(f) else "no frame"
        v = self.velocity
        return f"DetectedObject({span}, velocity=({v[0]:.3g}, {v[1]:.3g}), score={self.score:g})"
