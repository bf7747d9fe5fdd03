"""Detection and tracking of moving objects by branching segment sequences (SPEC §3.1–3.3,
source [K93]); the branching runs in Rust (``kalmanfield._core.BranchingTracker``), its twin is
:mod:`kalmanfield.reference.branching` (the module docstring there states every rule).

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

import numbers
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from . import _core
from ._validation import (
    SeedLike,
    nonnegative_int,
    positive_float,
    positive_int,
    probability,
    real_array,
    real_number,
    real_value,
    resolve_seed,
)

__all__ = ["BranchingTracker"]

#: the largest |measurement| accepted: the filters square differences of measurements, and
#: beyond ~1e154 those squares leave float64 (1e200 gave NaN tracks)
MAX_MEASUREMENT = 1e150

#: the most parameters a measurement vector may have (each has its own filter and column)
MAX_PARAMS = 2**16

_STATS_COLUMNS = ["measurements", "live_before", "children", "live", "seeds", "bookkeeping"]


def _per_param(value: Any, k: int, name: str, kind: type = float) -> list:
    """One value per parameter (a scalar is repeated)."""
    values = [value] * k if np.ndim(value) == 0 else list(np.asarray(value).ravel())
    if len(values) != k:
        raise ValueError(f"{name} needs {k} values (one per parameter), got {len(values)}")
    out = []
    for v in values:
        number = real_value(v, name, "hold real numbers")
        if kind is not int:
            out.append(number)
        elif isinstance(v, numbers.Integral):
            out.append(int(v))
        elif number.is_integer():
            out.append(int(number))
        else:
            raise TypeError(f"{name} must hold integers, got {v!r}")
    return out


def _default_names(k: int, n_spatial: int) -> list[str]:
    spatial = ["x", "y", "z"][:n_spatial] if n_spatial <= 3 else []
    if len(spatial) != n_spatial:
        spatial = [f"x{q}" for q in range(n_spatial)]
    return spatial + [f"p{q}" for q in range(n_spatial, k)]


class BranchingTracker:
    """Branching segment-sequence tracker (SPEC §3.1–3.3, [K93]), Rust core.

    Parameters
    ----------
    n_params : k, length of a measurement vector (at most 2**16); the first ``n_spatial``
        entries are positions (default min(k, 2)).
    order : ν per parameter (scalar or one per parameter, ≤ 4); default 1 (nearly constant
        velocity).
    process_std : std of the white (ν+1)-th derivative per parameter (px/frame² for ν = 1).
    measurement_std : measurement noise std per parameter. The stds, ``dt``, ``max_speed``
        and ``maneuver_std`` must be at most 1e100 (the filters square them).
    confidence : β of the χ² index test (SPEC §3.2).
    memory : N, number of index increments kept (sliding memory; 1…256).
    max_misses : longest run of coasted (missed) frames of a sequence.
    dt : frame step when :meth:`update` gets no time.
    p_detect : detection probability used by the score.
    clutter_density : clutter points per unit of parameter space per frame; ``None`` =
        estimated from the measurement counts and their bounding box. The score of a start
        uses its spatial part: λ times the extent seen so far of the non-spatial parameters,
        each floored at its measurement's resolution √(2π)·measurement_std (a constant
        parameter does not inflate the start scores).
    max_speed : maximum speed (spatial units per time) between the first ν+1 points of a
        sequence (the least-squares start is gated by it).
    n_confirm, confirm_llr, confirm_window : a sequence is confirmed once it has ``n_confirm``
        measurements and score ≥ ``confirm_llr``; unconfirmed ones die ``confirm_window``
        frames after their start (default n_confirm + max_misses + 1).
    delete_llr : sequential (SPRT-style) deletion: an unconfirmed sequence whose score falls
        below it dies at once (default −5: about two misses without a good measurement;
        ``None`` = the literal [K93] rule, time-out only). It halves the live sequences under
        clutter at no measured loss (README, tracking tables).
    max_per_tree, max_hypotheses, max_seeds : hypothesis limits (per track tree, global, new
        sequences per frame).
    max_children : most measurements a sequence branches on per frame (per variant, when
        ``maneuver_std`` adds one): the nearest in its gate, by increment δ, or by distance
        for a start point (ties: the earlier measurement); ``None`` = every measurement in
        the gate, the literal [K93] rule. Not in [K93]: a wide gate in dense measurements
        (5,000 per frame with ``measurement_std=100``) otherwise makes a child per pair
        before pruning, gigabytes per frame; rule 3 keeps ``max_per_tree`` + 2 children per
        tree anyway, so the default (2 × ``max_per_tree``) drops only children it would
        prune.
    merge_depth : D, last measurements that identify a sequence's future (pruning; 1…256).
    maneuver_std, maneuver_prob : optional velocity-jump branch per parameter (not in [K93]):
        a second child per gated measurement with an extra velocity jump of that std and prior
        probability; it lets sequences survive sharp turns (targets bouncing off borders).
    min_hits, final_llr : filter of the final answer (default ``n_confirm`` and 5).
    max_shared : measurements a chosen sequence may lose to better ones (final answer).
    selection : ``"llr"`` (default), or the literal rules ``"index_per_dof"`` / ``"pvalue"``.
    names : column names of the parameters in :meth:`tracks` (default x, y, then p2, p3…).
    seed : seed of the deterministic subset of new starts when there are more than
        ``max_seeds``: an int in [0, 2**64), or a numpy Generator / None (OS entropy) as for
        the fields.

    Configuration used for the anchor benchmark (20 targets, 50 clutter points per frame,
    targets bouncing off the borders): ``process_std=0.1, measurement_std=0.5,
    max_misses=3, maneuver_std=1.5, maneuver_prob=0.001`` (``benches/bench_tracking.py``).

    The tracker pickles: the pickled object resumes exactly where it stopped.
    """

    def __init__(
        self,
        n_params: int = 2,
        *,
        order: int | Sequence[int] = 1,
        process_std: float | Sequence[float] = 0.1,
        measurement_std: float | Sequence[float] = 0.5,
        confidence: float = 0.99,
        memory: int = 4,
        max_misses: int = 2,
        dt: float = 1.0,
        p_detect: float = 0.9,
        clutter_density: float | None = None,
        max_speed: float = 6.0,
        n_spatial: int | None = None,
        n_confirm: int = 4,
        confirm_llr: float = 0.0,
        confirm_window: int | None = None,
        delete_llr: float | None = -5.0,
        max_per_tree: int = 8,
        max_hypotheses: int = 20_000,
        max_seeds: int = 2_000,
        max_children: int | None = 16,
        merge_depth: int = 3,
        maneuver_std: float | Sequence[float] | None = None,
        maneuver_prob: float = 0.01,
        min_hits: int | None = None,
        final_llr: float = 5.0,
        max_shared: int = 2,
        selection: str = "llr",
        names: Sequence[str] | None = None,
        seed: SeedLike = 0,
    ) -> None:
        k = positive_int(n_params, "n_params")
        if k > MAX_PARAMS:  # (2**62 ran out of memory building the per-parameter lists)
            raise ValueError(f"n_params must be at most {MAX_PARAMS}, got {k}")
        s = min(k, 2) if n_spatial is None else positive_int(n_spatial, "n_spatial")
        if s > k:
            raise ValueError(f"n_spatial ({s}) cannot exceed n_params ({k})")
        n_confirm = positive_int(n_confirm, "n_confirm")
        max_misses = nonnegative_int(max_misses, "max_misses")
        orders = [nonnegative_int(o, "order") for o in _per_param(order, k, "order", int)]
        if max(orders) > _core.MAX_MOTION_ORDER:
            raise ValueError(f"order must be at most {_core.MAX_MOTION_ORDER}, got {max(orders)}")
        if selection not in ("llr", "index_per_dof", "pvalue"):
            raise ValueError(
                f"selection must be 'llr', 'index_per_dof' or 'pvalue', got {selection!r}"
            )
        names = _default_names(k, s) if names is None else [str(n) for n in names]
        if len(names) != k or len(set(names)) != k:
            raise ValueError(f"names must be {k} distinct column names, got {names}")
        seed = resolve_seed(seed)
        self._config: dict[str, Any] = dict(
            order=orders,
            process_std=_per_param(process_std, k, "process_std"),
            measurement_std=_per_param(measurement_std, k, "measurement_std"),
            n_spatial=s,
            confidence=probability(confidence, "confidence"),
            memory=positive_int(memory, "memory"),
            max_misses=max_misses,
            dt=positive_float(dt, "dt"),
            p_detect=probability(p_detect, "p_detect"),
            clutter_density=(
                None
                if clutter_density is None
                else positive_float(clutter_density, "clutter_density")
            ),
            max_speed=positive_float(max_speed, "max_speed"),
            n_confirm=n_confirm,
            confirm_llr=real_number(confirm_llr, "confirm_llr"),
            confirm_window=(
                n_confirm + max_misses + 1
                if confirm_window is None
                else positive_int(confirm_window, "confirm_window")
            ),
            delete_llr=None if delete_llr is None else real_number(delete_llr, "delete_llr"),
            max_per_tree=positive_int(max_per_tree, "max_per_tree"),
            max_hypotheses=positive_int(max_hypotheses, "max_hypotheses"),
            max_seeds=positive_int(max_seeds, "max_seeds"),
            max_children=(
                None if max_children is None else positive_int(max_children, "max_children")
            ),
            merge_depth=positive_int(merge_depth, "merge_depth"),
            maneuver_std=(
                None if maneuver_std is None else _per_param(maneuver_std, k, "maneuver_std")
            ),
            maneuver_prob=probability(maneuver_prob, "maneuver_prob"),
            min_hits=n_confirm if min_hits is None else positive_int(min_hits, "min_hits"),
            final_llr=real_number(final_llr, "final_llr"),
            max_shared=nonnegative_int(max_shared, "max_shared"),
            selection=selection,
            seed=seed,
        )
        self._names = names
        self._core = _core.BranchingTracker(**self._config)

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
    def config(self) -> dict[str, Any]:
        """The validated configuration (keyword → value)."""
        return dict(self._config)

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
        offsets = np.concatenate([[0], np.cumsum([o + 1 for o in self._config["order"]])])
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
        return {"config": self._config, "names": self._names, "state": self._core.state_bytes()}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self._config = dict(state["config"])
        self._config.setdefault("max_children", None)  # pickled before the cap existed
        self._names = list(state["names"])
        self._core = _core.BranchingTracker(**self._config)
        self._core.load_state(state["state"])

    def __repr__(self) -> str:
        return (
            f"BranchingTracker(n_params={self.n_params}, frames={self.frame}, "
            f"live sequences={self.n_hypotheses})"
        )
