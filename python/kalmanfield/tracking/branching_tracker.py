"""Detection and tracking of moving objects by branching segment sequences (SPEC §3.1–3.3,
source [K93]); the branching runs in Rust (``kalmanfield._core.BranchingTracker``), its twin is
:mod:`kalmanfield.reference.tracking.branching` (the module docstring there states every rule).

Summary of the method
---------------------
Each detection is a parameter vector z = (z_1..z_k): positions first (``n_spatial`` of them),
then any other parameter (amplitude, area, extents…). Every parameter has its own polynomial
Kalman filter of order ν (SPEC §3.1; process noise = white (ν+1)-th derivative of std
``process_std``). A sequence ("hypothesis") accumulates the likelihood index I, the sum of its
last N = ``memory`` normalised innovations (SPEC §3.2); a measurement joins a sequence only if
the new index stays below the χ² quantile of confidence β for k·n degrees of freedom — this
test *is* the gate. Every frame, every live sequence branches over the measurements of its
gate, plus a "missed" branch while its run of misses stays ≤ ``max_misses``; measurements no
confirmed sequence uses start new sequences (SPEC §3.3). Sequences are ranked by a
log-likelihood-ratio score against clutter; five pruning rules keep the work per frame bounded
(at most ``max_hypotheses`` continuing sequences, ``max_per_tree`` per track tree, plus at most
``max_seeds`` new ones per frame). The final answer takes sequences greedily in decreasing
score, never two sharing a measurement (a later one may lose up to ``max_shared`` detections,
reported as coasted frames).

Degradation under heavy clutter: the caps bound memory and time per frame; when they bind,
confirmed sequences are kept first and the new starts are a deterministic random subset, so
quality (not time) degrades.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from .. import _core
from .._validation import real_array, real_number
from .config import TrackerConfig

__all__ = ["BranchingTracker"]

#: the largest |measurement| accepted: the filters square differences of measurements, and
#: beyond ~1e154 those squares leave float64 (1e200 gave NaN tracks)
MAX_MEASUREMENT = 1e150

_STATS_COLUMNS = ["measurements", "live_before", "children", "live", "seeds", "bookkeeping"]


def _default_names(k: int, n_spatial: int) -> list[str]:
    spatial = ["x", "y", "z"][:n_spatial] if n_spatial <= 3 else []
    if len(spatial) != n_spatial:
        spatial = [f"x{q}" for q in range(n_spatial)]
    return spatial + [f"p{q}" for q in range(n_spatial, k)]


def _names(names: Sequence[str] | None, config: TrackerConfig, k: int) -> list[str]:
    assert config.n_spatial is not None  # (a configuration checked by for_params)
    out = _default_names(k, config.n_spatial) if names is None else [str(n) for n in names]
    if len(out) != k or len(set(out)) != k:
        raise ValueError(f"names must be {k} distinct column names, got {out}")
    return out


class BranchingTracker:
    """Branching segment-sequence tracker (method page *Tracking*, [K93]), Rust core.

    Each detection is a parameter vector z = (z_1..z_k): positions first (``n_spatial`` of
    them), then any other parameter (amplitude, area, extents…). Every parameter has its own
    polynomial Kalman filter; a sequence accumulates the sliding likelihood index, whose χ²
    test is the gate; every frame each live sequence branches over the measurements of its
    gate (plus a missed branch), five pruning rules bound the work, and the final answer
    takes sequences greedily by score, never two sharing a measurement.

    Parameters
    ----------
    n_params : int
        k, the length of a measurement vector (at most 2**16).
    config : TrackerConfig, optional
        The settings (default: ``TrackerConfig()``).
    names : sequence of str, optional
        Column names of the parameters in :meth:`tracks` (default x, y, then p2, p3…).
    **settings
        Any field of :class:`TrackerConfig`, overriding `config`'s.

    Raises
    ------
    TypeError
        An unknown setting, or a setting of the wrong type.
    ValueError
        A setting out of its range (the message names it).

    Notes
    -----
    Configuration of the anchor benchmark (20 targets bouncing off the borders, 50 clutter
    points per frame): ``process_std=0.1, measurement_std=0.5, max_misses=3,
    maneuver_std=1.5, maneuver_prob=0.001``. The per-frame work depends on the scene only,
    not on how many frames came before. The tracker pickles: the unpickled copy resumes
    exactly where it stopped.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> tracker = kf.BranchingTracker(2, measurement_std=0.3)
    >>> for t in range(8):
    ...     tracker.update(np.array([[10.0 + 2 * t, 5.0 + t]]))
    >>> tracker.tracks()["particle"].nunique()
    1
    """

    def __init__(
        self,
        n_params: int = 2,
        config: TrackerConfig | None = None,
        *,
        names: Sequence[str] | None = None,
        **settings: Any,
    ) -> None:
        if config is None:
            config = TrackerConfig()
        elif not isinstance(config, TrackerConfig):
            raise TypeError(f"config must be a TrackerConfig, got {type(config).__name__}")
        if settings:
            config = TrackerConfig.from_settings(
                {**config.as_dict(), **settings}, caller="BranchingTracker"
            )
        self._config = config.for_params(n_params)
        self._names = _names(names, self._config, int(n_params))
        self._core = _core.BranchingTracker(self._config)

    # ------------------------------------------------------------------ properties
    @property
    def n_params(self) -> int:
        """k, the length of a measurement vector."""
        return len(self._names)

    @property
    def names(self) -> list[str]:
        """Column names of the parameters."""
        return list(self._names)

    @property
    def config(self) -> TrackerConfig:
        """The checked configuration (every setting concrete, one value per parameter)."""
        return self._config

    @property
    def frame(self) -> int:
        """Number of frames processed."""
        return self._core.frame

    @property
    def time(self) -> float | None:
        """Time of the last frame (None before the first)."""
        return self._core.time

    @property
    def n_hypotheses(self) -> int:
        """Live sequences after the last frame."""
        return self._core.n_hypotheses

    # ------------------------------------------------------------------ per frame
    def update(self, measurements: npt.ArrayLike | pd.DataFrame, time: float | None = None) -> None:
        """Processes one frame (SPEC §3.3 step 2–3).

        ``measurements``: an (m, k) array-like of parameter vectors (any detector's output; an
        empty frame is ``np.empty((0, k))`` or ``[]``), or a DataFrame holding the columns
        :attr:`names`. ``time``: the frame's time (default: previous time + ``dt``; must
        increase). NaN/inf measurements, measurements beyond ±``MAX_MEASUREMENT`` (1e150), a
        wrong column count, a non-increasing time, a time beyond ±1e150 or a time step so long
        that the predicted covariances overflow float64 raise ValueError before anything
        changes.
        """
        k = self.n_params
        if isinstance(measurements, pd.DataFrame):
            missing = [n for n in self._names if n not in measurements.columns]
            if missing:
                raise ValueError(f"the DataFrame lacks the columns {missing}")
            # column by column: a DataFrame[list] selection costs more than the tracking
            measurements = np.column_stack([measurements[n].to_numpy() for n in self._names])
        z = real_array(measurements, "measurements")
        if z.size == 0:
            z = np.empty((0, k))
        if z.ndim == 1 and k == 1:
            z = z[:, None]
        if z.ndim != 2 or z.shape[1] != k:
            raise ValueError(f"measurements must be an (m, {k}) array, got shape {z.shape}")
        if not np.isfinite(z).all():
            raise ValueError("measurements must be finite (no NaN or inf); drop such rows first")
        if z.size and np.abs(z).max() > MAX_MEASUREMENT:
            raise ValueError(
                f"measurements must lie within ±{MAX_MEASUREMENT:g} (the filters square them); "
                "rescale or re-centre the parameters"
            )
        if time is not None:
            time = real_number(time, "time")
        self._core.update(z, time)

    # ------------------------------------------------------------------ answers
    def tracks(self, online: bool = False) -> pd.DataFrame:
        """Per-frame estimates of the chosen sequences (SPEC §3.3 step 3), coasted frames
        included.

        Columns: ``frame``, ``particle``, the parameters (filtered estimates, named
        :attr:`names`), their derivatives ``<name>_d1``…, ``detection`` (global detection id:
        the running number of the measurement over all frames, −1 when coasted), ``coasted``,
        ``index`` (the sliding index I, SPEC §3.2) and ``score``. ``online=True`` gives the
        per-frame online answer instead (particle = track-tree id, decided at each frame
        without hindsight).
        """
        if online:
            o = self._core.online()
            data: dict[str, Any] = {"frame": o["frame"], "particle": o["tree"]}
            for q, name in enumerate(self._names):
                data[name] = o["position"][:, q]
            data["coasted"] = o["coasted"]
            data["score"] = o["score"]
            return pd.DataFrame(data)
        t = self._core.tracks()
        state = t["state"]
        offsets = np.concatenate([[0], np.cumsum(np.asarray(self._config.order) + 1)])
        data = {"frame": t["frame"], "particle": t["particle"]}
        for q, name in enumerate(self._names):
            data[name] = state[:, offsets[q]]
        for q, name in enumerate(self._names):
            for j in range(1, offsets[q + 1] - offsets[q]):
                data[f"{name}_d{j}"] = state[:, offsets[q] + j]
        data["detection"] = t["detection"]
        data["coasted"] = t["detection"] < 0
        data["index"] = t["index"]
        data["score"] = t["score"]
        return pd.DataFrame(data)

    def stats(self) -> pd.DataFrame:
        """Per frame: measurements, live sequences before, children formed, live after
        pruning, new sequences, and the records the frame's bookkeeping visited (track trees,
        pruning's per-tree and per-measurement tables, nodes scanned by a compaction): the
        cost of each frame, which depends on the scene, not on how many frames came before."""
        return pd.DataFrame(self._core.stats(), columns=_STATS_COLUMNS)

    def detection_frame(self, detection: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """(frame, row within that frame's measurements) of global detection ids."""
        gid = np.asarray(detection, dtype=np.int64)
        offsets = self._core.frame_offsets()
        if gid.size and (gid.min() < 0 or gid.max() >= self._n_measurements()):
            raise ValueError("detection ids must be in [0, number of measurements so far)")
        frame = np.searchsorted(offsets, gid, side="right") - 1
        return frame, gid - offsets[frame]

    def _n_measurements(self) -> int:
        stats = self._core.stats()
        return int(stats[:, 0].sum()) if len(stats) else 0

    # ------------------------------------------------------------------ pickling
    def __getstate__(self) -> dict[str, Any]:
        return {
            "config": self._config.as_dict(),
            "names": self._names,
            "state": self._core.state_bytes(),
        }

    def __setstate__(self, state: dict[str, Any]) -> None:
        if not isinstance(state, dict) or not {"config", "names", "state"} <= set(state):
            raise ValueError("a BranchingTracker state is a dict of config, names and state")
        settings = state["config"]
        if not isinstance(settings, dict):
            raise TypeError(f"the pickled config must be a dict, got {type(settings).__name__}")
        settings = {"max_children": None, **settings}  # pickled before the cap existed
        names = state["names"]
        if not isinstance(names, (list, tuple)):
            raise TypeError(f"the pickled names must be a list, got {type(names).__name__}")
        config = TrackerConfig.from_settings(settings, caller="BranchingTracker.__setstate__")
        k = len(names)
        self._config = config.for_params(k)
        self._names = _names(names, self._config, k)
        self._core = _core.BranchingTracker(self._config)
        self._core.load_state(state["state"])

    def __repr__(self) -> str:
        return (
            f"BranchingTracker(n_params={self.n_params}, frames={self.frame}, "
            f"live sequences={self.n_hypotheses})"
        )
