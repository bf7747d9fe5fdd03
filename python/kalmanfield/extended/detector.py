"""Detection of moving objects made of fragments, frame by frame (method page *Extended
objects*, §3.4): segmentation, then stage 2 in Rust (``kalmanfield._core.GroupTracker``,
twin :mod:`kalmanfield.reference.extended`), or stage 1 alone (the branching tracker)."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, cast

import numpy as np
import numpy.typing as npt
import pandas as pd

from .. import _core
from .._validation import positive_float, positive_int, probability, real_number
from ..tracking import BranchingTracker
from .detected import DetectedObject
from .frames import (
    FrameCheck,
    background_level,
    box_mean,
    box_smooth,
    noise_level,
    segment_frame,
)
from .options import DetectorOptions

__all__ = ["MovingObjectDetector", "detect_moving_objects"]

_MODES = ("auto", "point", "extended")
#: "auto": a segment of the first frame larger than this (pixels) means extended objects
POINT_AREA = 9.0
_FRAGMENT_COLUMNS = ["frame", "fragment", "x", "y", "amplitude", "area"]
_TRACK_COLUMNS = ["frame", "x", "y", "vx", "vy"]


class _Records:
    """What an object accumulates: track rows, fragment rows, pixels per frame."""

    def __init__(self) -> None:
        self.track: list[list[float]] = []
        self.fragments: list[list[float]] = []
        self.pixels: dict[int, np.ndarray] = {}

    def absorb(self, other: _Records) -> None:
        frames = {int(r[0]) for r in self.track}
        self.track = sorted(self.track + [r for r in other.track if int(r[0]) not in frames])
        self.fragments = sorted(self.fragments + other.fragments)
        for f, p in other.pixels.items():
            self.pixels[f] = np.union1d(self.pixels.get(f, np.zeros(0, np.int64)), p)


class MovingObjectDetector:
    """The streaming form of :func:`detect_moving_objects`.

    Feed frames with :meth:`update`, read :meth:`objects` at any time; it pickles mid-scene
    and resumes exactly.

    Parameters
    ----------
    noise_std : float, optional
        As :func:`detect_moving_objects`.
    dt : float, default 1.0
        As :func:`detect_moving_objects`.
    confidence : float, default 0.99
        As :func:`detect_moving_objects`.
    memory : int, default 4
        As :func:`detect_moving_objects`.
    mode : {"auto", "point", "extended"}, default "auto"
        As :func:`detect_moving_objects`.
    threshold : float, optional
        As :func:`detect_moving_objects`.
    **options
        As :func:`detect_moving_objects`.

    Raises
    ------
    ValueError, TypeError
        As :func:`detect_moving_objects`.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> scene = kf.simulate_scene((48, 48), 8, targets=1, snr=6.0, p_false=0.0, dt=1.0,
    ...                           seed=1)
    >>> det = kf.MovingObjectDetector(noise_std=1.0)
    >>> for frame in scene.frames:
    ...     det.update(frame)
    >>> len(det.objects()) >= 1
    True
    """

    def __init__(
        self,
        *,
        noise_std: float | None = None,
        dt: float = 1.0,
        confidence: float = 0.99,
        memory: int = 4,
        mode: str = "auto",
        threshold: float | None = None,
        **options: Any,
    ) -> None:
        self._noise_std = None if noise_std is None else positive_float(noise_std, "noise_std")
        self._dt = positive_float(dt, "dt")
        self._confidence = probability(confidence, "confidence")
        self._memory = positive_int(memory, "memory")
        if not isinstance(mode, str) or mode not in _MODES:
            raise ValueError(f"mode must be one of {_MODES}, got {mode!r}")
        self._mode = mode
        self._threshold = None if threshold is None else real_number(threshold, "threshold")
        self._options = DetectorOptions.build(options)
        self._check = FrameCheck()
        self._frame = 0
        self._smoothed: np.ndarray | None = None  # scratch for the smoothed frame
        self._core: Any = None  # _core.GroupTracker or BranchingTracker, made at frame 0
        self._groups: Any = None  # "auto" staged: the seeded stage-2 GroupTracker
        self._records: dict[int, _Records] = {}
        self._points: list[tuple[int, float, float, float, float, np.ndarray]] = []
        self._promoted: set[int] = set()  # stage-1 detections handed over to stage 2

    @property
    def frame(self) -> int:
        """Frames processed so far."""
        return self._frame

    @property
    def mode(self) -> str:
        """The mode: "point", "extended" or "staged" ("auto" once decided by the first frame).

        "staged": stage 1, then stage 2 seeded with each confirmed trajectory whose segment
        grows beyond points.
        """
        return self._mode

    @property
    def order(self) -> int:
        """The centroid motion order ν."""
        return self._options.order

    @property
    def noise_std(self) -> float | None:
        """The noise std given or estimated from the first frame."""
        return self._noise_std

    def update(self, frame: npt.ArrayLike) -> None:
        """Process the next frame.

        Parameters
        ----------
        frame : array_like
            A 2-D frame of the shape and dtype of the first one (NaN pixels are missing).

        Raises
        ------
        ValueError
            A frame of another shape or dtype, not 2-D, with an infinite value or no finite
            pixel.
        TypeError
            A non-numeric frame.
        """
        image = self._check.frame(frame, self._frame)
        if self._noise_std is None:
            self._noise_std = noise_level(image)
            if not self._noise_std > 0:
                raise ValueError(
                    "the noise std estimated from the first frame is 0: give noise_std"
                )
        if self._smoothed is None:  # reused (every frame has the first one's shape): a new
            self._smoothed = np.empty(image.shape)  # 512² array costs ~0.85 ms of page faults
        smoothed = box_smooth(image, self._options.smooth, self._smoothed)
        if self._options.background_width:  # a textured background: subtract its local level
            smoothed = smoothed - box_mean(smoothed, self._options.background_width)
        threshold = self._threshold
        if threshold is None:
            threshold = self._auto_threshold(smoothed)
        table, labels, label_image = segment_frame(
            smoothed, threshold, self._options.min_area, self._options.connectivity
        )
        if self._core is None:
            self._start(table)
        if self._mode == "point":
            self._update_points(table, labels, label_image)
        elif self._mode == "staged":
            self._update_staged(table, labels, label_image)
        else:
            self._update_groups(self._core, table, labels, label_image)
        self._frame += 1

    def _auto_threshold(self, smoothed: np.ndarray) -> float:
        """median of the smoothed frame + threshold_k × σ / smooth (the white noise's std
        after the box mean)."""
        assert self._noise_std is not None
        spread = self._noise_std / self._options.smooth
        return background_level(smoothed) + self._options.threshold_k * spread

    def _start(self, table: np.ndarray) -> None:
        if self._mode == "auto":
            extended = len(table) > 0 and float(np.max(table[:, 3])) > POINT_AREA
            self._mode = "extended" if extended else "staged"
        assert self._noise_std is not None
        config = self._options.core_config(
            dt=self._dt,
            noise_std=self._noise_std,
            confidence=self._confidence,
            memory=self._memory,
            seed_groups=self._mode == "extended",
        )
        if self._mode == "staged":
            self._groups = _core.GroupTracker(**config)
        if self._mode == "extended":
            self._core = _core.GroupTracker(**config)
        else:
            self._core = BranchingTracker(
                2,
                dt=self._dt,
                confidence=self._confidence,
                memory=self._memory,
                measurement_std=config["position_std"],
                process_std=config["process_std"],
            )

    @staticmethod
    def _pixels(label_image: np.ndarray, row: np.ndarray, label: int) -> np.ndarray:
        x0, y0, x1, y1 = (int(v) for v in row[4:8])
        box = label_image[y0 : y1 + 1, x0 : x1 + 1] == label
        rr, cc = np.nonzero(box)
        return ((rr + y0) * label_image.shape[1] + cc + x0).astype(np.int64)

    def _update_groups(
        self, core: Any, table: np.ndarray, labels: np.ndarray, label_image: np.ndarray
    ) -> dict[str, Any]:
        answer: dict[str, Any] = core.step(table)
        for absorbed, into in answer["merged"]:
            if int(absorbed) in self._records:
                self._records.setdefault(int(into), _Records()).absorb(
                    self._records.pop(int(absorbed))
                )
        member = answer["segment_member"]
        hidden = set(answer["hidden"].tolist())
        for row in answer["groups"]:
            gid = int(row[0])
            held = answer["segment_group"] == gid
            if row[5] > 0:
                chosen = np.flatnonzero(member & held)
            elif gid in self._records and held.any():
                # detected before, its fragments restructured: it stays detected (its image:
                # the segments its group holds)
                chosen = np.flatnonzero(held)
            elif gid in self._records and gid in hidden:
                # hidden in another object's segment: its predicted centre, no pixels of its own
                self._records[gid].track.append([self._frame, *row[1:5]])
                continue
            else:
                continue
            rec = self._records.setdefault(gid, _Records())
            rec.track.append([self._frame, *row[1:5]])
            parts = []
            for r in chosen:
                z = table[r]
                rec.fragments.append(
                    [self._frame, int(answer["segment_sequence"][r]), z[0], z[1], z[2], z[3]]
                )
                parts.append(self._pixels(label_image, z, int(labels[r])))
            rec.pixels[self._frame] = np.sort(np.concatenate(parts))
        return answer

    def _update_points(
        self, table: np.ndarray, labels: np.ndarray, label_image: np.ndarray
    ) -> None:
        self._core.update(table[:, :2])
        for r, z in enumerate(table):
            pixels = self._pixels(label_image, z, int(labels[r]))
            self._points.append((self._frame, z[0], z[1], z[2], z[3], pixels))

    def _update_staged(
        self, table: np.ndarray, labels: np.ndarray, label_image: np.ndarray
    ) -> None:
        """Mode "auto" from a point-like first frame: stage 2 takes the segments of the
        objects already handed over, stage 1 the others; a confirmed stage-1 trajectory whose
        segment of this frame exceeds POINT_AREA seeds a stage-2 group (method page, §3.4)."""
        answer = self._update_groups(self._groups, table, labels, label_image)
        free = np.flatnonzero(answer["segment_group"] < 0)
        first = len(self._points)
        self._update_points(table[free], labels[free], label_image)
        grown = [k for k, r in enumerate(free) if table[r, 3] > POINT_AREA]
        if not grown:
            return
        tracks = self._core.tracks()
        now = tracks[(tracks["frame"] == self._frame) & ~tracks["coasted"]]
        taken = np.zeros(len(table), dtype=bool)
        for k in grown:
            hit = now[now["detection"] == first + k]
            r = int(free[k])
            if hit.empty or taken[r]:
                continue
            t = tracks[(tracks["particle"] == hit["particle"].iloc[0]) & ~tracks["coasted"]]
            members = self._seed_members(table, free, r, taken)
            taken[members] = True
            gid = self._groups.seed(
                table[members], float(hit["x_d1"].iloc[0]), float(hit["y_d1"].iloc[0]), len(t)
            )
            self._hand_over(gid, t, table, labels, label_image, members)

    def _seed_members(
        self, table: np.ndarray, free: np.ndarray, r: int, taken: np.ndarray
    ) -> np.ndarray:
        """Segment r and the free segments whose centroid lies in its box grown by the gate
        margin (the fragments of the object in its first stage-2 frame)."""
        x0, y0, x1, y1 = table[r, 4:8]
        m = self._options.gate_margin
        z = table[free]
        near = (z[:, 0] >= x0 - m) & (z[:, 0] <= x1 + m) & (z[:, 1] >= y0 - m) & (z[:, 1] <= y1 + m)
        chosen = free[near & ~taken[free]]
        return np.union1d(chosen, [r]).astype(np.int64)

    def _hand_over(
        self,
        gid: int,
        t: pd.DataFrame,
        table: np.ndarray,
        labels: np.ndarray,
        label_image: np.ndarray,
        members: np.ndarray,
    ) -> None:
        """The seeded group's record starts with its stage-1 trajectory (track, fragments,
        pixels) and this frame's seed segments."""
        rec = self._records.setdefault(int(gid), _Records())
        for row in t.itertuples():
            d = int(row.detection)
            self._promoted.add(d)
            p = self._points[d]
            rec.track.append([int(row.frame), row.x, row.y, row.x_d1, row.y_d1])
            if int(row.frame) != self._frame:
                rec.fragments.append([p[0], -1, p[1], p[2], p[3], p[4]])
                rec.pixels[p[0]] = p[5]
        parts = []
        for r in members:
            z = table[r]
            rec.fragments.append([self._frame, -1, z[0], z[1], z[2], z[3]])
            parts.append(self._pixels(label_image, z, int(labels[r])))
        rec.pixels[self._frame] = np.sort(np.concatenate(parts))

    def objects(self) -> list[DetectedObject]:
        """Return the objects found so far, best first.

        Returns
        -------
        list of DetectedObject
            Ranked as by :func:`detect_moving_objects`.
        """
        if self._check.shape is None:
            return []
        if self._mode == "point":
            return self._point_objects()
        out = self._point_objects() if self._mode == "staged" else []
        for gid, rec in self._records.items():
            track = _frame_of(rec.track, _TRACK_COLUMNS, 1)
            fragments = _frame_of(rec.fragments, _FRAGMENT_COLUMNS, 2)
            out.append(
                DetectedObject(
                    track,
                    fragments,
                    dict(rec.pixels),
                    self._check.shape,
                    self._score(track),
                    id=gid,
                )
            )
        return _ranked(out)

    def _score(self, track: pd.DataFrame) -> float:
        """Path length travelled while detected, Σ |v| τ over the detected frames, capped by
        the net displacement between the first and last detected centres (pixels)."""
        if track.empty:
            return 0.0
        path = float(np.hypot(track["vx"], track["vy"]).sum() * self._dt)
        x, y = track["x"].to_numpy(), track["y"].to_numpy()
        return min(path, float(np.hypot(x[-1] - x[0], y[-1] - y[0])))

    def _point_objects(self) -> list[DetectedObject]:
        tracks = self._core.tracks()
        tracks = tracks[~tracks["coasted"]]
        out = []
        assert self._check.shape is not None
        for particle, t in tracks.groupby("particle", sort=True):
            if self._promoted.intersection(t["detection"].tolist()):
                continue  # handed over to stage 2: reported as its group
            rows = [self._points[int(d)] for d in t["detection"]]
            track = pd.DataFrame(
                {
                    "frame": t["frame"].to_numpy(np.int64),
                    "x": t["x"].to_numpy(),
                    "y": t["y"].to_numpy(),
                    "vx": t["x_d1"].to_numpy(),
                    "vy": t["y_d1"].to_numpy(),
                }
            )
            fragments = _frame_of(
                [[r[0], int(particle), r[1], r[2], r[3], r[4]] for r in rows], _FRAGMENT_COLUMNS, 2
            )
            pixels = {int(r[0]): r[5] for r in rows}
            out.append(
                DetectedObject(
                    track,
                    fragments,
                    pixels,
                    self._check.shape,
                    self._score(track),
                    id=int(particle),
                )
            )
        return _ranked(out)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_smoothed"] = None  # a scratch buffer
        for key in ("_core", "_groups"):
            if isinstance(state.get(key), _core.GroupTracker):
                state[key] = ("group", bytes(state[key].state_bytes()))
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        for key in ("_core", "_groups"):
            core = state.get(key)
            if isinstance(core, tuple):
                if len(core) != 2 or core[0] != "group" or not isinstance(core[1], bytes):
                    raise ValueError("not a MovingObjectDetector state")
                state[key] = _core.GroupTracker.from_state(core[1])
        self.__dict__.update(state)

    def __repr__(self) -> str:
        return f"MovingObjectDetector(mode={self._mode!r}, frames={self._frame})"


def _frame_of(rows: list[list[float]], columns: list[str], n_int: int) -> pd.DataFrame:
    """A DataFrame of `rows`, its first `n_int` columns int64, the others float64 (built
    column by column: far cheaper than a DataFrame of lists and ``astype``)."""
    a = np.asarray(rows, dtype=np.float64).reshape(-1, len(columns))
    data = {
        name: a[:, k].astype(np.int64) if k < n_int else a[:, k] for k, name in enumerate(columns)
    }
    return pd.DataFrame(data)


def _ranked(objects: list[DetectedObject]) -> list[DetectedObject]:
    return sorted(objects, key=lambda o: (-o.score, -len(o.track), o.id))


def detect_moving_objects(
    frames: npt.ArrayLike | Iterable[npt.ArrayLike],
    *,
    noise_std: float | None = None,
    dt: float = 1.0,
    confidence: float = 0.99,
    memory: int = 4,
    mode: str = "auto",
    threshold: float | None = None,
    **options: Any,
) -> list[DetectedObject]:
    """Moving objects in a frame sequence, each a group of fragments moving together.

    Parameters
    ----------
    frames : array_like or iterable of array_like
        An (F, H, W) array or any iterable of 2-D frames of one shape and dtype (read one at a
        time: memory does not grow with F beyond the objects' records). NaN pixels (or masked
        ones) are missing: they take the frame's median and are never foreground alone.
    noise_std : float, optional
        The std σ of the white noise; estimated from the first frame
        (:func:`kalmanfield.estimate_sigma`) when None.
    dt : float, default 1.0
        Time between frames (velocities are in pixels per this unit).
    confidence : float, default 0.99
        The confidence β of the χ² test of every sequence (§3.2).
    memory : int, default 4
        N: index increments kept (N + 1 observations).
    mode : {"auto", "point", "extended"}, default "auto"
        "point": stage 1 only (the branching tracker on the segment centroids, one fragment per
        object); "extended": stage 2 from the first frame; "auto": "extended" when a segment
        of the first frame exceeds 9 pixels, else stage 1 first and stage 2 seeded (with
        stage 1's velocity) by each confirmed trajectory once its segment exceeds 9 pixels.
    threshold : float, optional
        Segmentation threshold on the smoothed frame. When None, per frame: the median of the
        smoothed frame (of every 4th row and column beyond 256² pixels) + ``threshold_k`` ×
        σ / ``smooth`` (the noise std after the ``smooth`` × ``smooth`` box mean).
        On a textured background give ``background_width`` (below).
    **options
        Fields of ``DetectorOptions`` (smooth=3, threshold_k=3.0, background_width=0 (w > 0:
        subtract the w × w local mean of the smoothed frame first), min_area=3,
        connectivity=8, order=1, position_std=1.0, process_std, amplitude_std,
        log_area_std=0.5, feature_drift=0.5, initial_speed_std, gate_margin=2.0,
        min_speed, velocity_tolerance, cohesion=0.0 (c > 0: co-moving groups within c × their
        size of each other are one object), max_misses=2); see the method page.

    Returns
    -------
    list of DetectedObject
        Best first: by score, the path length Σ ``|v|`` τ travelled while detected, capped by
        the net displacement of the centre (an object seen longer and moving faster and
        steadier ranks higher: moving background is assumed slower than the object, the
        source's Remark 1), then by frames detected.

    Raises
    ------
    ValueError
        Frames of different shapes or dtypes, frames that are not 2-D, infinite pixels, a
        frame without any finite pixel, non-positive `noise_std` or `dt`, `confidence`
        outside (0, 1), an unknown `mode`, bad options.
    TypeError
        Non-numeric frames, unknown options.

    See Also
    --------
    MovingObjectDetector : The same, frame by frame (pickles).
    simulate_scene : Scenes with ground truth.

    Notes
    -----
    Each frame is box-smoothed, thresholded and segmented (:func:`kalmanfield.segment`); the
    segments go to stage 2 of [K93] (Rust): grouping of segment sequences that share the
    object's velocity, the greedy assignment under the χ² gate, new and vanishing fragments,
    and the merge rule (length > ν + 1, similar non-zero velocity). Method page
    :doc:`/methods/extended_objects`, §3.4.

    Examples
    --------
    >>> import kalmanfield as kf
    >>> scene = kf.simulate_scene((64, 64), 10, targets=1, snr=5.0, p_false=0.1, dt=0.1,
    ...                           seed=3)
    >>> objects = kf.detect_moving_objects(scene.frames, noise_std=1.0, dt=0.1)
    >>> list(objects[0].track.columns)
    ['frame', 'x', 'y', 'vx', 'vy']
    """
    detector = MovingObjectDetector(
        noise_std=noise_std,
        dt=dt,
        confidence=confidence,
        memory=memory,
        mode=mode,
        threshold=threshold,
        **options,
    )
    if isinstance(frames, np.ndarray) and frames.ndim != 3:
        raise ValueError(
            f"frames must be an (F, H, W) array or an iterable of 2-D frames, got {frames.ndim}-D"
        )
    for frame in cast(Iterable[Any], frames):
        detector.update(frame)
    needed = detector.order + 1
    if detector.frame < needed:
        raise ValueError(
            f"need at least {needed} frames (the motion order ν + 1), got {detector.frame}"
        )
    return detector.objects()
