"""Detection and tracking of moving objects by branching segment sequences ([K93]); the
branching runs in Rust (``kalmanfield._core.BranchingTracker``), its twin is
:mod:`kalmanfield.reference.tracking.branching` (the module docstring there states every rule).
The method, every rule and every choice where the source is silent: method page *Tracking*,
§3.1–3.3.
"""

from __future__ import annotations

import warnings
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

#: settings younger than the first pickles, with the value that resumes such a pickle exactly
LEGACY_SETTINGS = {"max_children": None, "diffusion_std": 0.0, "commit_lag": None}

_STATS_COLUMNS = ["measurements", "live_before", "children", "live", "seeds", "bookkeeping"]


class TrackTable(pd.DataFrame):
    """The table of :meth:`BranchingTracker.tracks`: a DataFrame whose ``["index"]`` still
    gives the ``likelihood_index`` column, with a DeprecationWarning (the column was called
    ``index`` in 0.1.0, a name that clashes with ``DataFrame.index``)."""

    @property
    def _constructor(self) -> type[TrackTable]:
        return TrackTable

    def __getitem__(self, key: Any) -> Any:
        if (
            isinstance(key, str)
            and key == "index"
            and "index" not in self.columns
            and "likelihood_index" in self.columns
        ):
            warnings.warn(
                "the tracks' column 'index' is now 'likelihood_index'",
                DeprecationWarning,
                stacklevel=2,
            )
            key = "likelihood_index"
        return super().__getitem__(key)


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
    n_params : int, default 2
        The length k of a measurement vector (at most 2**16).
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

    See Also
    --------
    TrackerConfig : Every setting, with its default.
    link : The tracker run over a trackpy-style detection table.
    segment : Detections from a frame.

    Notes
    -----
    Configuration of the anchor benchmark (20 targets bouncing off the borders, 50 clutter
    points per frame): ``process_std=0.1, measurement_std=0.5, max_misses=3,
    maneuver_std=1.5, maneuver_prob=0.001``. The per-frame work depends on the scene only,
    not on how many frames came before. The tracker pickles: the unpickled copy resumes
    exactly where it stopped. The method (§3.1–3.3) and the choices made where the source is
    silent are on :doc:`/methods/tracking`.

    References
    ----------
    .. [1] V. K. Klochko, "Detection of moving images of point and extended objects in a
       sequence of television frames", Avtometriya, 1993, no. 1 ([K93] in
       :doc:`/references`).

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
        """The length k of a measurement vector."""
        return len(self._names)

    @property
    def names(self) -> list[str]:
        """The column names of the parameters (a list)."""
        return list(self._names)

    @property
    def config(self) -> TrackerConfig:
        """The checked configuration, every setting concrete (a TrackerConfig)."""
        return self._config

    @property
    def frame(self) -> int:
        """The number of frames processed."""
        return self._core.frame

    @property
    def time(self) -> float | None:
        """The time of the last frame (None before the first)."""
        return self._core.time

    @property
    def n_hypotheses(self) -> int:
        """The number of live sequences after the last frame."""
        return self._core.n_hypotheses

    # ------------------------------------------------------------------ per frame
    def update(self, measurements: npt.ArrayLike | pd.DataFrame, time: float | None = None) -> None:
        """Process one frame (§3.3, steps 2–3, of :doc:`/methods/tracking`).

        Parameters
        ----------
        measurements : array_like or pandas.DataFrame
            An (m, k) array of parameter vectors (any detector's output; an empty frame is
            ``np.empty((0, k))`` or ``[]``), or a DataFrame holding the columns
            :attr:`names`.
        time : float, optional
            The frame's time (default: the previous time + ``dt``); must increase.

        Raises
        ------
        ValueError
            NaN or infinite measurements, measurements beyond ±1e150, a wrong column count,
            a non-increasing time, a time beyond ±1e150 or a time step so long that the
            predicted covariances overflow float64. Nothing changes then.
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
        """Per-frame estimates of the chosen sequences, coasted frames included.

        Parameters
        ----------
        online : bool, default False
            Give the per-frame online answer instead (particle = track-tree id, decided at
            each frame without hindsight).

        Returns
        -------
        pandas.DataFrame
            Columns ``frame``, ``particle``, the parameters (filtered estimates, named
            :attr:`names`), their derivatives ``<name>_d1``…, ``detection`` (the running
            number of the measurement over all frames, −1 when coasted), ``coasted``,
            ``likelihood_index`` (the sliding likelihood index I, §3.2; ``["index"]`` still
            reads it, deprecated) and ``score``. The online answer has ``frame``,
            ``particle``, the parameters, ``coasted`` and ``score``.

        Notes
        -----
        The final answer takes sequences greedily by score, never two sharing a measurement
        (§3.3, step 3, of :doc:`/methods/tracking`).
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
        data["likelihood_index"] = t["index"]
        data["score"] = t["score"]
        return TrackTable(data)

    def stats(self) -> pd.DataFrame:
        """The work of every frame so far.

        Returns
        -------
        pandas.DataFrame
            One row per frame: ``measurements``, ``live_before`` (live sequences before),
            ``children`` (formed), ``live`` (after pruning), ``seeds`` (new sequences) and
            ``bookkeeping`` (records visited: track trees, pruning tables, nodes scanned by a
            compaction). It depends on the scene, not on how many frames came before.
        """
        return pd.DataFrame(self._core.stats(), columns=_STATS_COLUMNS)

    def detection_frame(self, detection: npt.ArrayLike) -> tuple[np.ndarray, np.ndarray]:
        """Frame and row of global detection ids.

        Parameters
        ----------
        detection : array_like of int
            Detection ids (the ``detection`` column of :meth:`tracks`).

        Returns
        -------
        frame : numpy.ndarray
            The frame of each id.
        row : numpy.ndarray
            Its row within that frame's measurements.

        Raises
        ------
        ValueError
            Ids outside [0, number of measurements so far).
        """
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
        settings = {**LEGACY_SETTINGS, **settings}
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
