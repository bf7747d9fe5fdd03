"""Plain-NumPy reference of the branching segment-sequence tracker (method page *Tracking*,
§3.1–3.3, [K93]).

Written for clarity, as the twin the Rust ``kalmanfield.BranchingTracker`` will be checked
against. SciPy is optional (``cKDTree`` for the gating look-up; a chunked brute-force search is
used without it); the χ² quantiles are computed here.

Model (§3.1)
-----------------
Each detection is a parameter vector z = (z_1..z_k) (x, y, then any other parameter). Every
parameter q has its own polynomial Kalman filter of order ν_q: state (x_q, ẋ_q, …, x_q^(ν_q)),
F_q = Taylor matrix of the step τ, H = (1, 0, …), measurement variance R_q = measurement_std_q².
Process noise: a white (ν_q+1)-th derivative held constant over the step, of std process_std_q,
so Q_q = σ_q² g gᵀ with g_i = τ^(ν_q+1-i)/(ν_q+1-i)! (ν = 1: the discrete white-noise
acceleration model, g = (τ²/2, τ)), plus diffusion_std_q² τ on the value (a random walk of
the value itself: with ν = 1, drift plus diffusion).

Index (§3.2)
-----------------
Increment of a measured frame: δ = Σ_q (z_q − Hᵀ F X̂_q)² / D_q. The index I is the sum of the last
N = ``memory`` increments (frames with a miss add none, so "last N increments" = last N measured
frames). A branch is accepted while I ≤ α(k·n), the χ² quantile of confidence β for k·n degrees of
freedom, n = min(#increments, N). This test *is* the gate: a measurement is a candidate for a
sequence iff δ ≤ α(k·n_new) − (sum of the increments that stay in the window). The first ν_max+1
measurements of a sequence are the least-squares start (§3.3 step 1, "I = 0 for least-squares
starts"): they add no increment; the second and later start points are gated by a maximum speed
instead (‖Δposition‖ ≤ max_speed·Δt + 3√2·σ, σ the largest spatial measurement std).

Branching (§3.3 step 2) and pruning
----------------------------------------
Per frame every live sequence ("hypothesis") branches over every measurement inside its gate,
plus one "missed" branch (the coasted prediction) while its current run of misses stays
≤ ``max_misses``. Not in [K93]: at most ``max_children`` measurements per sequence and variant,
the nearest (smallest increment δ; for a start point, smallest distance to its last position;
ties: the earlier measurement), so a gate holding thousands of measurements cannot make
gigabytes of children before pruning. Sequences descending from one start form a *track tree*.
The children are pruned, in this order:

1. tentative time-out: a sequence not confirmed ``confirm_window`` frames after its start dies,
   and so does an unconfirmed one whose score is below ``delete_llr`` (sequential deletion, as
   the lower threshold of Wald's test in SPRT track confirmation; ``None`` = off);
2. merging inside a tree: children with the same last ``merge_depth`` measurements and the same
   current run of misses are the same future; only the best (highest score, below) is kept;
3. at most ``max_per_tree`` best children per tree, plus two protected ones: the tree's best, and
   its best *exclusive* child (sharing none of its last ``merge_depth`` measurements with the
   best child of another tree). Without the protection, when two targets come close, both
   trees keep only variants that follow the same target and the other target is lost;
4. cross-tree duplicates: when sequences of two trees share their last ``merge_depth``
   measurements and the younger one (started strictly later) has at most ν_max+1
   measurements the older one does not have (the same target started later, or started on
   one stray point), the younger one dies;
   then the N-scan commitment (``commit_lag``, not in [K93]): the greedy answer over the
   children (below) commits to the tree of each of its sequences the final answer could
   take the measurement it took ``commit_lag`` frames ago, and every sequence of another
   tree holding that measurement dies (a confirmed one offers its last measured node before
   that frame as its tree's candidate). Without it each tree keeps, for every future, the
   best past on its own, and the trees of two close targets all adopt the same past;
5. global cap ``max_hypotheses``: children of confirmed sequences first, then by score.

Every rule bounds the work per frame: at most ``max_hypotheses`` continuing sequences (plus at
most ``max_seeds`` new starts), each with the
measurements of its gate; at extreme clutter the cap and ``max_seeds`` decide what is kept
(confirmed sequences first), so the cost per frame stays bounded and the quality degrades.

Sequences start (§3.3 step 3) from every measurement of the frame that no *confirmed*
sequence uses (at most ``max_seeds`` per frame: when there are more, those with the smallest
splitmix64 hash of seed ^ global id, a deterministic random subset). A sequence is confirmed
once it has ``n_confirm`` measurements and score ≥ ``confirm_llr``.

Score: log-likelihood ratio against clutter
-------------------------------------------
The raw index cannot rank sequences of different lengths (a 3-point sequence of clutter has a
smaller I than a 100-frame true track), and χ²/dof or a p-value does not reward length either.
Sequences are ranked by the standard track score (log-likelihood ratio of "target" against
"clutter of density λ", Sittler/Blackman):

    measured frame:    ΔL = ln P_d − ln λ − ½ Σ_q ln(2π D_q) − ½ δ
    start point ≥ 2:   ΔL = ln P_d − ln(λ_s · V_speed)         (uniform inside the speed gate)
    missed frame:      ΔL = ln(1 − P_d)

(λ = clutter density in the k-dimensional parameter space, λ_s its spatial part: a given λ
times the extent seen so far of the non-spatial parameters (max − min over every measurement,
this frame's included, floored at the resolution √(2π)·σ_q of its measurement, the width of
its noise law: the extent ~0 of a constant parameter would otherwise make λ_s ~0 and inflate
every start point's score); if not given, both are estimated as the mean number of
measurements per frame over the bounding box seen so far, its spans floored at 1.)
It is a monotone function of the index for equal lengths and miss patterns, grows with the
length of a good sequence and falls with misses, clutter-like jumps and a high clutter density.

Final answer (§3.3 step 3)
-------------------------------
Candidates: the live confirmed sequences and, for each track tree that died, its best confirmed
sequence that ended by running out of misses (trailing misses cut). Candidates with at least
``min_hits`` measurements and score ≥ ``final_llr`` are taken greedily in decreasing score (the
"increasing index" of the source, with the score in place of the raw index for the reason
above). Relaxation of "never two sharing a segment": a candidate sharing at most ``max_shared``
measurements with the sequences already taken is accepted with those frames coasted (two close
targets may swap one detection without costing a track its identity); one sharing more is cut
at the shared measurements and its pieces go back into the queue with the score gained over the
piece. ``selection="index_per_dof"`` or ``"pvalue"`` give the literal rule for comparison
(whole sequences, no sharing, ranked by the final window index over its degrees of freedom or
by its χ² p-value). Per frame, an online answer is also recorded: the live confirmed
sequences chosen greedily by score, at most one per tree and one per measurement of the frame.

Optional extension (not in [K93]): ``maneuver_std`` adds, for each gated measurement, a second
child updated with an extra velocity jump of that std (prior probability ``maneuver_prob``,
score ln p); rule 2 keeps whichever of the two explains the measurement better. It lets the
sequences survive sharp turns (targets bouncing off the frame borders).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from ...tracking.config import TrackerConfig

try:  # optional accelerator for the gate look-up
    from scipy.spatial import cKDTree as _KDTree
except ImportError:  # pragma: no cover
    _KDTree = None

__all__ = ["BranchingTracker", "chi2_quantile", "link", "motion_matrices"]

_NONE = -2  # "no entry yet" in the recent-entries key
_MISS = -1  # a missed (coasted) frame


# --------------------------------------------------------------------------------------------
# small numerical helpers
# --------------------------------------------------------------------------------------------


def _chi2_cdf(x: float, dof: int) -> float:
    """P(χ²_dof ≤ x) = regularised lower incomplete gamma P(dof/2, x/2)."""
    a, y = 0.5 * dof, 0.5 * x
    if y <= 0.0:
        return 0.0
    if y < a + 1.0:  # series
        term = total = 1.0 / a
        n = a
        for _ in range(10_000):
            n += 1.0
            term *= y / n
            total += term
            if abs(term) < abs(total) * 1e-15:
                break
        return total * math.exp(-y + a * math.log(y) - math.lgamma(a))
    # continued fraction (Lentz) for Q
    b = y + 1.0 - a
    c = 1.0 / 1e-300
    d = 1.0 / b
    h = d
    for i in range(1, 10_000):
        an = -i * (i - a)
        b += 2.0
        d = an * d + b
        d = 1e-300 if abs(d) < 1e-300 else d
        c = b + an / c
        c = 1e-300 if abs(c) < 1e-300 else c
        d = 1.0 / d
        delta = d * c
        h *= delta
        if abs(delta - 1.0) < 1e-15:
            break
    return 1.0 - math.exp(-y + a * math.log(y) - math.lgamma(a)) * h


def chi2_quantile(beta: float, dof: int) -> float:
    """χ² quantile α with P(χ²_dof ≤ α) = β (bisection; §3.2 threshold α_μ)."""
    if not 0.0 < beta < 1.0:
        raise ValueError("confidence must be in (0, 1)")
    lo, hi = 0.0, max(1.0, dof)
    while _chi2_cdf(hi, dof) < beta:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if _chi2_cdf(mid, dof) < beta:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def motion_matrices(
    order: int, tau: float, process_std: float, diffusion_std: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """(F, Q) of one parameter (§3.1): F[i, j] = τ^(j−i)/(j−i)!, Q = σ² g gᵀ + σ_D² τ e₀e₀ᵀ,
    g_i = τ^(ν+1−i)/(ν+1−i)! (σ_D: the diffusion of the value itself)."""
    d = order + 1
    F = np.zeros((d, d))
    for i in range(d):
        for j in range(i, d):
            F[i, j] = tau ** (j - i) / math.factorial(j - i)
    g = np.array([tau ** (d - i) / math.factorial(d - i) for i in range(d)])
    Q = process_std**2 * np.outer(g, g)
    Q[0, 0] += diffusion_std * diffusion_std * tau
    return F, Q


def splitmix64(x: np.ndarray) -> np.ndarray:
    """The splitmix64 finaliser of uint64 values (wrapping arithmetic): the portable hash that
    picks the deterministic subset of new sequences when there are more than ``max_seeds``."""
    with np.errstate(over="ignore"):
        z = np.asarray(x, dtype=np.uint64) + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


def _log_ball_volume(r: np.ndarray, dim: int) -> np.ndarray:
    return math.log(math.pi ** (dim / 2) / math.gamma(dim / 2 + 1)) + dim * np.log(r)


def _ball_pairs(points: np.ndarray, centres: np.ndarray, radii: np.ndarray):
    """All (centre i, point j) with ‖points_j − centres_i‖ ≤ radii_i, as two index arrays."""
    if len(points) == 0 or len(centres) == 0:
        e = np.zeros(0, dtype=np.int64)
        return e, e
    if _KDTree is not None:
        lists = _KDTree(points).query_ball_point(centres, radii)
        lens = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
        pi = np.repeat(np.arange(len(centres)), lens)
        pj = np.fromiter((j for x in lists for j in x), dtype=np.int64, count=int(lens.sum()))
        return pi, pj
    out_i, out_j = [], []
    step = max(1, 2_000_000 // max(1, len(points)))
    for s in range(0, len(centres), step):
        c = centres[s : s + step]
        d2 = ((c[:, None, :] - points[None, :, :]) ** 2).sum(-1)
        ii, jj = np.nonzero(d2 <= radii[s : s + step, None] ** 2)
        out_i.append(ii + s)
        out_j.append(jj)
    return np.concatenate(out_i), np.concatenate(out_j)


def _row_keys(a: np.ndarray) -> np.ndarray:
    """One hashable void scalar per row of an int64 array (for np.unique over rows)."""
    a = np.ascontiguousarray(a, dtype=np.int64)
    return a.view(np.dtype((np.void, a.dtype.itemsize * a.shape[1]))).ravel()


# --------------------------------------------------------------------------------------------
# storage
# --------------------------------------------------------------------------------------------


class _Nodes:
    """Append-only store of the sequence trees: one node per (sequence, frame).

    parent (−1 for a start), frame, meas (global detection id, −1 = missed), the filtered state
    (concatenated over parameters), the index I, the score. A sequence is the parent chain of
    its leaf node; ``compact`` drops nodes no live sequence or candidate reaches.
    """

    def __init__(self, n_state: int):
        self.n = 0
        self.n_state = n_state
        cap = 1024
        self.parent = np.empty(cap, np.int64)
        self.frame = np.empty(cap, np.int64)
        self.meas = np.empty(cap, np.int64)
        self.state = np.empty((cap, n_state))
        self.index = np.empty(cap)
        self.llr = np.empty(cap)

    def add(self, parent, frame, meas, state, index, llr) -> np.ndarray:
        m = len(parent)
        need = self.n + m
        if need > len(self.parent):
            cap = max(need, 2 * len(self.parent))
            for name in ("parent", "frame", "meas", "index", "llr"):
                old = getattr(self, name)
                new = np.empty(cap, old.dtype)
                new[: self.n] = old[: self.n]
                setattr(self, name, new)
            st = np.empty((cap, self.n_state))
            st[: self.n] = self.state[: self.n]
            self.state = st
        s = slice(self.n, need)
        self.parent[s] = parent
        self.frame[s] = frame
        self.meas[s] = meas
        self.state[s] = state
        self.index[s] = index
        self.llr[s] = llr
        ids = np.arange(self.n, need)
        self.n = need
        return ids

    def chain(self, leaf: int) -> np.ndarray:
        """Node ids of the sequence ending at ``leaf``, oldest first."""
        out = []
        p = self.parent
        while leaf >= 0:
            out.append(leaf)
            leaf = int(p[leaf])
        return np.array(out[::-1], dtype=np.int64)

    def compact(self, roots: np.ndarray) -> np.ndarray:
        """Keep the nodes reachable from ``roots``; returns the old→new id map (−1 = dropped)."""
        keep = np.zeros(self.n, bool)
        front = np.unique(roots[roots >= 0])
        while len(front):
            front = front[~keep[front]]
            keep[front] = True
            front = np.unique(self.parent[front])
            front = front[front >= 0]
        remap = np.full(self.n + 1, -1, np.int64)  # index −1 → −1
        kept = np.flatnonzero(keep)
        remap[kept] = np.arange(len(kept))
        for name in ("parent", "frame", "meas", "index", "llr"):
            arr = getattr(self, name)
            setattr(self, name, arr[kept].copy())
        self.state = self.state[kept].copy()
        self.parent = remap[self.parent]
        self.n = len(kept)
        return remap


@dataclass
class _Hyps:
    """Live sequences (struct of arrays, one row per sequence)."""

    node: np.ndarray  # leaf node id
    tree: np.ndarray  # track tree id
    X: list  # per parameter (H, d_q)
    P: list  # per parameter (H, d_q, d_q)
    inc: np.ndarray  # (H, N) last N increments, oldest first, zero padded on the left
    n_inc: np.ndarray  # number of increments so far
    I_tot: np.ndarray  # sum of all increments
    llr: np.ndarray  # score
    hits: np.ndarray  # measured frames
    miss: np.ndarray  # current run of misses
    t_last: np.ndarray  # time of the last measured frame
    pos_last: np.ndarray  # (H, s) spatial measurement of the last measured frame
    llr_last: np.ndarray  # score at the last measured frame
    node_last: np.ndarray  # node of the last measured frame
    recent: np.ndarray  # (H, D) ids of the last D measured frames (−2 = none yet)
    cur: np.ndarray  # entry of the newest frame: measurement id or −1 (missed)
    conf: np.ndarray  # confirmed
    start: np.ndarray  # frame of the first measurement

    def take(self, idx) -> _Hyps:
        return _Hyps(
            **{  # type: ignore[arg-type]
                f: ([a[idx] for a in v] if isinstance(v, list) else v[idx])
                for f, v in self.__dict__.items()
            }
        )

    @property
    def size(self) -> int:
        return len(self.llr)


# --------------------------------------------------------------------------------------------
# the tracker
# --------------------------------------------------------------------------------------------


class BranchingTracker:
    """Branching segment-sequence tracker, NumPy reference (§3.1–3.3).

    Parameters
    ----------
    n_params : int
        k, the length of a measurement vector.
    config : TrackerConfig, optional
        The settings, as for :class:`kalmanfield.BranchingTracker` (one definition).
    names : sequence of str, optional
        Column names of the parameters in ``tracks()``.
    **settings
        Any field of :class:`kalmanfield.tracking.config.TrackerConfig`.
    """

    def __init__(
        self,
        n_params: int = 2,
        config: TrackerConfig | None = None,
        *,
        names: Sequence[str] | None = None,
        **settings,
    ):
        config = (config or TrackerConfig()).replace(**settings)
        c = config.for_params(n_params)
        assert c.n_spatial is not None and c.confirm_window is not None
        assert c.min_hits is not None
        k = int(n_params)
        self.k = k
        self.s = c.n_spatial
        self.order = list(c.order)  # type: ignore[arg-type]
        self.sigma_w = list(c.process_std)  # type: ignore[arg-type]
        self.sigma_d = list(c.diffusion_std)  # type: ignore[arg-type]
        self.R = np.array([v**2 for v in c.measurement_std])  # type: ignore[union-attr]
        self.man: list[float] | None = (
            None if c.maneuver_std is None else [float(v) for v in c.maneuver_std]  # type: ignore[union-attr]
        )
        self.man_prob = c.maneuver_prob
        self.d = [o + 1 for o in self.order]
        self.off = np.concatenate([[0], np.cumsum(self.d)]).astype(int)
        self.nu_max = max(self.order)
        self.beta = c.confidence
        self.N = c.memory
        self.alpha = np.array(
            [0.0] + [chi2_quantile(self.beta, k * n) for n in range(1, self.N + 1)]
        )
        self.max_misses = c.max_misses
        self.dt = c.dt
        self.pd = c.p_detect
        self.lam = c.clutter_density
        self.vmax = c.max_speed
        self.n_confirm = c.n_confirm
        self.confirm_llr = c.confirm_llr
        self.delete_llr = -np.inf if c.delete_llr is None else c.delete_llr
        self.confirm_window = c.confirm_window
        self.K = c.max_per_tree
        self.max_h = c.max_hypotheses
        self.max_seeds = c.max_seeds
        self.max_children = c.max_children
        self.D = c.merge_depth
        self.commit_lag = c.commit_lag
        self.min_hits = c.min_hits
        self.final_llr = c.final_llr
        self.max_shared = c.max_shared
        self.selection = c.selection
        if names is None:  # spatial x, y, z (x0, x1… beyond three), then p<q>
            spatial = ["x", "y", "z"][: self.s] if self.s <= 3 else [f"x{q}" for q in range(self.s)]
            names = spatial + [f"p{q}" for q in range(self.s, k)]
        self.names = list(names)
        self.seed = int(c.seed)  # type: ignore[arg-type]
        # prior variance of the derivatives of a start (diffuse: the start is least squares)
        self._p0 = [
            np.diag([self.R[q]] + [(10.0 * self.vmax) ** 2] * self.order[q]) for q in range(k)
        ]
        self.nodes = _Nodes(int(self.off[-1]))
        self.h = self._empty()
        self.frame = 0
        self.t: float | None = None
        self.n_meas = 0
        self._meas: list[np.ndarray] = []
        self._lo = np.full(k, np.inf)
        self._hi = np.full(k, -np.inf)
        self.tree_conf = np.zeros(0, bool)
        self.tree_cand = np.zeros(0, np.int64)  # best terminated confirmed node per tree
        self.tree_cand_llr = np.zeros(0)
        self.tree_alive = np.zeros(0, bool)
        self.finished: list[tuple[int, float]] = []  # (leaf node, score)
        self._online: list[tuple] = []
        self._compact_at = 200_000
        self.stats: list[dict] = []

    # ---------------------------------------------------------------- helpers
    def _empty(self) -> _Hyps:
        z = np.zeros(0)
        zi = np.zeros(0, np.int64)
        return _Hyps(
            node=zi,
            tree=zi,
            X=[np.zeros((0, d)) for d in self.d],
            P=[np.zeros((0, d, d)) for d in self.d],
            inc=np.zeros((0, self.N)),
            n_inc=zi,
            I_tot=z,
            llr=z,
            hits=zi,
            miss=zi,
            t_last=z,
            pos_last=np.zeros((0, self.s)),
            llr_last=z,
            node_last=zi,
            recent=np.zeros((0, self.D), np.int64),
            cur=zi,
            conf=np.zeros(0, bool),
            start=zi,
        )

    def _log_density(self, measured: int) -> tuple[float, float]:
        """(ln λ, ln λ_s): logarithms of the clutter density in parameter space and in the
        spatial sub-space (sums of logarithms: products of wide spans overflow);
        ``measured`` = all measurements so far, this frame's included."""
        if self.lam is not None:
            span = np.maximum(self._hi - self._lo, np.sqrt(2.0 * np.pi * self.R))
            extra = float(np.log(span[self.s :]).sum())
            return math.log(self.lam), math.log(self.lam) + extra
        ln_span = np.log(np.maximum(self._hi - self._lo, 1.0))
        ln_rate = math.log(max(measured / max(self.frame + 1, 1), 1.0))
        return ln_rate - float(ln_span.sum()), ln_rate - float(ln_span[: self.s].sum())

    def _state_flat(self, X: list) -> np.ndarray:
        return np.concatenate(X, axis=1) if X else np.zeros((0, 0))

    # ---------------------------------------------------------------- per frame
    def update(self, measurements, time: float | None = None) -> None:
        """Process one frame: ``measurements`` is an (m, k) array of parameter vectors."""
        Z = np.asarray(measurements, dtype=float).reshape(-1, self.k)
        if not np.all(np.isfinite(Z)):
            raise ValueError("measurements must be finite")
        t = (0.0 if self.t is None else self.t + self.dt) if time is None else float(time)
        tau = 0.0 if self.t is None else t - self.t
        if self.t is not None and tau <= 0:
            raise ValueError("time must increase")
        M = len(Z)
        gid0 = self.n_meas
        self._meas.append(Z.copy())
        if M:
            self._lo = np.minimum(self._lo, Z.min(0))
            self._hi = np.maximum(self._hi, Z.max(0))
        h = self.h
        H = h.size
        st = {"frame": self.frame, "measurements": M, "live_before": H}
        if H:
            ch, term = self._branch(h, Z, tau, t, gid0)
            st["children"] = ch.size
            self._terminate(h, term)
            ch = self._prune(ch)
            h = self._commit(ch)
        else:
            h = self._empty()
        # trees that lost every sequence: their best terminated confirmed sequence is final
        alive = np.zeros(len(self.tree_alive), bool)
        alive[h.tree] = True
        died = np.flatnonzero(self.tree_alive & ~alive)
        for tr in died:
            if self.tree_conf[tr] and self.tree_cand[tr] >= 0:
                self.finished.append((int(self.tree_cand[tr]), float(self.tree_cand_llr[tr])))
        self.tree_alive = alive
        # new sequences from measurements not used by confirmed sequences (§3.3 step 3)
        used = np.zeros(M, bool)
        rec = h.cur
        u = rec[h.conf & (rec >= gid0)] - gid0 if h.size else rec
        used[u] = True
        new = np.flatnonzero(~used)
        if len(new) > self.max_seeds:
            key = splitmix64(np.uint64(self.seed) ^ (gid0 + new).astype(np.uint64))
            new = np.sort(new[np.lexsort((new, key))[: self.max_seeds]])
        h = self._seed(h, Z, new, t, gid0)
        self.h = h
        self._online_answer(h, t, gid0)
        st["live"] = h.size
        st["seeds"] = len(new)
        self.stats.append(st)
        self.n_meas += M
        self.t = t
        self.frame += 1
        if self.nodes.n > self._compact_at:
            self._compact()

    def _branch(self, h: _Hyps, Z: np.ndarray, tau: float, t: float, gid0: int):
        """Predict, gate and branch every live sequence (§3.1, §3.2, §3.3 step 2)."""
        k, s, H = self.k, self.s, h.size
        ln_lam, ln_lam_s = self._log_density(gid0 + len(Z))
        Xp, Pp, S, Pm, Sm = [], [], np.empty((H, k)), [], np.empty((H, k))
        for q in range(k):
            F, Q = motion_matrices(self.order[q], tau, self.sigma_w[q], self.sigma_d[q])
            x = h.X[q] @ F.T
            P = F @ h.P[q] @ F.T + Q
            Xp.append(x)
            Pp.append(P)
            S[:, q] = P[:, 0, 0] + self.R[q]
            if self.man is not None:
                # velocity jump at the last measured frame: g = (t − t_last, 1, 0, …)
                g = np.zeros((H, self.d[q]))
                g[:, 0] = (t - h.t_last) if self.d[q] > 1 else 1.0
                if self.d[q] > 1:
                    g[:, 1] = 1.0
                P2 = P + self.man[q] ** 2 * g[:, :, None] * g[:, None, :]
                Pm.append(P2)
                Sm[:, q] = P2[:, 0, 0] + self.R[q]
        ls = h.hits <= self.nu_max  # still in the least-squares start
        n_new = np.minimum(h.n_inc + 1, self.N)
        gate = np.maximum(self.alpha[n_new] - h.inc[:, 1:].sum(1), 0.0)
        Smax = S[:, :s].max(1) if self.man is None else np.maximum(S, Sm)[:, :s].max(1)
        r = np.sqrt(gate * Smax)
        pred = np.stack([Xp[q][:, 0] for q in range(s)], axis=1)
        r_ls = self.vmax * (t - h.t_last) + 3.0 * math.sqrt(2.0 * self.R[:s].max())
        centre = np.where(ls[:, None], h.pos_last, pred)
        r = np.where(ls, r_ls, r)
        pi, pj = _ball_pairs(Z[:, :s], centre, r)
        d2 = ((Z[pj, :s] - centre[pi]) ** 2).sum(1)

        parts = []  # (src, meas, X list, P list, inc or nan, dllr)
        if len(pi):
            ls_p = ls[pi]
            v = np.stack([Z[pj, q] - Xp[q][pi, 0] for q in range(k)], axis=1)
            variants = [(S, Pp, 0.0)]
            if self.man is not None:
                variants.append((Sm, Pm, math.log(self.man_prob)))
            for vi, (SS, PP, pen) in enumerate(variants):
                Sp = SS[pi]
                inc = (v**2 / Sp).sum(1)
                ok = ls_p | (inc <= gate[pi])
                if vi > 0:
                    ok &= ~ls_p
                ok &= self._nearest(pi, pj, np.where(ls_p, d2, inc), ok)
                if not ok.any():
                    continue
                a, b, vv, Sa, inc_a = pi[ok], pj[ok], v[ok], Sp[ok], inc[ok]
                Xn, Pn = [], []
                for q in range(k):
                    Pq = PP[q][a]
                    Kg = Pq[:, :, 0] / Sa[:, q, None]
                    Xn.append(Xp[q][a] + Kg * vv[:, q, None])
                    Pn.append(Pq - Kg[:, :, None] * Kg[:, None, :] * Sa[:, q, None, None])
                lsa = ls_p[ok]
                dl = (
                    math.log(self.pd)
                    - ln_lam
                    - 0.5 * np.log(2 * math.pi * Sa).sum(1)
                    - 0.5 * inc_a
                    + pen
                )
                ln_vol = _log_ball_volume(r_ls[a], s) + ln_lam_s
                dl = np.where(lsa, math.log(self.pd) - ln_vol, dl)
                inc_a = np.where(lsa, np.nan, inc_a)
                parts.append((a, gid0 + b, Xn, Pn, inc_a, dl))
        can_miss = h.miss < self.max_misses
        mi = np.flatnonzero(can_miss)
        if len(mi):
            parts.append(
                (
                    mi,
                    np.full(len(mi), _MISS, np.int64),
                    [x[mi] for x in Xp],
                    [p[mi] for p in Pp],
                    np.full(len(mi), np.nan),
                    np.full(len(mi), math.log1p(-self.pd)),
                )
            )
        # sequences that end: no coasting left and no measurement in the gate
        has_hit = np.zeros(H, bool)
        for a, m, *_ in parts:
            has_hit[a[m >= 0]] = True
        term = np.flatnonzero(~can_miss & ~has_hit)

        if not parts:
            return self._empty(), term
        src = np.concatenate([p[0] for p in parts])
        meas = np.concatenate([p[1] for p in parts])
        Xc = [np.concatenate([p[2][q] for p in parts]) for q in range(k)]
        Pc = [np.concatenate([p[3][q] for p in parts]) for q in range(k)]
        incv = np.concatenate([p[4] for p in parts])
        dl = np.concatenate([p[5] for p in parts])
        hit = meas >= 0
        counted = hit & ~np.isnan(incv)
        c = h.take(src)
        c.X, c.P = Xc, Pc
        inc_sh = np.concatenate([c.inc[:, 1:], np.nan_to_num(incv)[:, None]], axis=1)
        c.inc = np.where(counted[:, None], inc_sh, c.inc)
        c.n_inc = c.n_inc + counted
        c.I_tot = c.I_tot + np.where(counted, np.nan_to_num(incv), 0.0)
        c.llr = c.llr + dl
        c.hits = c.hits + hit
        c.miss = np.where(hit, 0, c.miss + 1)
        c.t_last = np.where(hit, t, c.t_last)
        if len(Z):  # an empty frame has no hit
            last = Z[np.maximum(meas - gid0, 0)][:, :s]
            c.pos_last = np.where(hit[:, None], last, c.pos_last)
        c.llr_last = np.where(hit, c.llr, c.llr_last)
        c.node_last = np.where(hit, -1, c.node_last)  # filled in by _commit
        shifted = np.concatenate([c.recent[:, 1:], meas[:, None]], axis=1)
        c.recent = np.where(hit[:, None], shifted, c.recent)
        c.cur = meas
        c.conf = c.conf | ((c.hits >= self.n_confirm) & (c.llr >= self.confirm_llr))
        c.node = h.node[src]  # parent node until _commit
        return c, term

    def _nearest(self, pi: np.ndarray, pj: np.ndarray, key: np.ndarray, ok: np.ndarray):
        """Mask of the pairs kept by the cap: per sequence, the ``max_children`` ok pairs of
        smallest key (ties: smaller measurement index)."""
        if self.max_children is None:
            return ok
        cand = np.flatnonzero(ok)
        order = cand[np.lexsort((pj[cand], key[cand], pi[cand]))]
        seq = pi[order]
        first = np.searchsorted(seq, seq)  # start of each sequence's run in the sorted order
        rank = np.arange(len(order)) - first
        keep = np.zeros(len(ok), bool)
        keep[order[rank < self.max_children]] = True
        return keep

    def _terminate(self, h: _Hyps, term: np.ndarray) -> None:
        """Record ended confirmed sequences as the tree's candidate (best score wins)."""
        term = term[h.conf[term]]
        if not len(term):
            return
        for i in term[np.argsort(h.llr_last[term], kind="stable")]:
            tr = h.tree[i]
            if self.tree_cand[tr] < 0 or h.llr_last[i] > self.tree_cand_llr[tr]:
                self.tree_cand[tr] = h.node_last[i]
                self.tree_cand_llr[tr] = h.llr_last[i]

    def _prune(self, c: _Hyps) -> _Hyps:
        """Pruning rules 1–5 of the module docstring."""
        if c.size == 0:
            return c
        # 1. tentative time-out
        keep = c.conf | ((self.frame - c.start < self.confirm_window) & (c.llr >= self.delete_llr))
        c = c.take(np.flatnonzero(keep))
        if c.size == 0:
            return c
        # 2. merge inside a tree: same tree, same last D measurements, same miss run → best
        order = np.argsort(-c.llr, kind="stable")
        key = np.concatenate([c.tree[:, None], c.recent, c.miss[:, None]], axis=1)
        _, first = np.unique(_row_keys(key[order]), return_index=True)
        c = c.take(np.sort(order[first]))
        # 3. at most K per tree, plus each tree's best and best exclusive sequence
        protect = self._protected(c)
        order = np.lexsort((-c.llr, ~protect, c.tree))
        tr = c.tree[order]
        startpos = np.r_[0, np.flatnonzero(np.diff(tr)) + 1]
        rank = np.arange(len(tr)) - np.repeat(startpos, np.diff(np.r_[startpos, len(tr)]))
        c = c.take(np.sort(order[rank < self.K]))
        # 4. cross-tree duplicates
        c = self._cross_tree(c)
        # N-scan commitment to the online answer
        c = self._commit_to_online_answer(c)
        # 5. global cap
        if c.size > self.max_h:
            order = np.lexsort((-c.llr, ~c.conf))
            drop = order[self.max_h :]
            dropped = c.take(drop)
            # a confirmed sequence cut by the cap is a candidate like an ended one (its parent)
            for i in np.flatnonzero(dropped.conf):
                tr, par = dropped.tree[i], int(dropped.node[i])
                if self.tree_cand[tr] < 0 or self.nodes.llr[par] > self.tree_cand_llr[tr]:
                    self.tree_cand[tr] = par
                    self.tree_cand_llr[tr] = self.nodes.llr[par]
            c = c.take(np.sort(order[: self.max_h]))
        return c

    def _commit_to_online_answer(self, c: _Hyps) -> _Hyps:
        """N-scan commitment: the greedy answer over the children commits to the tree of each
        chosen sequence the final answer could take (score ≥ ``final_llr``, at least
        ``min_hits`` measurements) the measurement it took ``commit_lag`` frames ago; a sequence of
        another tree holding it dies (a confirmed one offers its last measured node before
        that frame as its tree's candidate)."""
        if self.commit_lag is None or c.size == 0:
            return c
        parent, meas = self.nodes.parent, self.nodes.meas
        back = c.node.copy()  # the children's nodes are their parents, of frame t − 1
        for _ in range(self.commit_lag - 1):
            back = np.where(back >= 0, parent[np.maximum(back, 0)], -1)
        held = np.where(back >= 0, meas[np.maximum(back, 0)], -1)
        owner: dict[int, int] = {}
        for i in self._greedy(c):
            if held[i] >= 0 and c.llr[i] >= self.final_llr and c.hits[i] >= self.min_hits:
                owner.setdefault(int(held[i]), int(c.tree[i]))
        lost = np.array(
            [
                held[i] >= 0 and owner.get(int(held[i]), c.tree[i]) != c.tree[i]
                for i in range(c.size)
            ],
            dtype=bool,
        )
        for i in np.flatnonzero(lost & c.conf):
            before = int(parent[back[i]])
            while before >= 0 and meas[before] < 0:
                before = int(parent[before])
            if before >= 0:
                tr = c.tree[i]
                if self.tree_cand[tr] < 0 or self.nodes.llr[before] > self.tree_cand_llr[tr]:
                    self.tree_cand[tr] = before
                    self.tree_cand_llr[tr] = self.nodes.llr[before]
        return c.take(np.flatnonzero(~lost)) if lost.any() else c

    def _cross_tree(self, c: _Hyps) -> _Hyps:
        """Rule 4: kill the younger of two trees' sequences sharing their last D entries when it
        has at most ν_max+1 measurements the older one lacks (strictly younger: of two starts
        of one frame, one may be the target's and the other a stray point whose sequence
        hopped onto it, and the score at the start does not tell them apart)."""
        informative = (c.recent >= 0).sum(1) >= 2
        idx = np.flatnonzero(informative)
        if len(idx) < 2:
            return c
        key = _row_keys(c.recent[idx])
        _, inv, cnt = np.unique(key, return_inverse=True, return_counts=True)
        dup = cnt[inv] > 1
        if not dup.any():
            return c
        idx, inv = idx[dup], inv[dup]
        dead = np.zeros(c.size, bool)
        for g in np.unique(inv):
            members = idx[inv == g]
            if len(np.unique(c.tree[members])) < 2:
                continue
            members = members[np.lexsort((-c.llr[members], c.start[members]))]
            kept: list[int] = []
            for y in members:  # oldest first, best score first among equals
                for o in kept:
                    if (
                        c.tree[o] != c.tree[y]
                        and c.start[o] < c.start[y]
                        and self._dominated(c, y, o)
                    ):
                        dead[y] = True
                        break
                else:
                    kept.append(int(y))
        return c.take(np.flatnonzero(~dead))

    def _dominated(self, c: _Hyps, y: int, o: int) -> bool:
        """True when sequence y has at most ν_max+1 measurements that sequence o lacks.

        Both chains hold one node per frame, so they are compared frame by frame back to the
        start of y, stopping as soon as the limit is passed."""
        limit = self.nu_max + 1
        extra = int(c.cur[y] >= 0 and c.cur[y] != c.cur[o])
        ny, no = int(c.node[y]), int(c.node[o])
        meas, parent, frame = self.nodes.meas, self.nodes.parent, self.nodes.frame
        since = int(c.start[y])
        while extra <= limit and ny >= 0 and frame[ny] >= since:
            my = meas[ny]
            if my >= 0 and (no < 0 or meas[no] != my):
                extra += 1
            ny = parent[ny]
            no = parent[no] if no >= 0 else -1
        return extra <= limit

    def _commit(self, c: _Hyps) -> _Hyps:
        """Store the surviving children as nodes."""
        if c.size == 0:
            return self._empty()
        ids = self.nodes.add(c.node, self.frame, c.cur, self._state_flat(c.X), c.inc.sum(1), c.llr)
        hit = c.cur >= 0
        c.node_last = np.where(hit, ids, c.node_last)
        c.node = ids
        self.tree_conf[c.tree[c.conf]] = True
        return c

    def _seed(self, h: _Hyps, Z: np.ndarray, new: np.ndarray, t: float, gid0: int) -> _Hyps:
        """Start one sequence (and one track tree) per measurement in ``new``."""
        m = len(new)
        if m == 0:
            return h
        k, s = self.k, self.s
        t0 = len(self.tree_conf)
        trees = np.arange(t0, t0 + m)
        self.tree_conf = np.concatenate([self.tree_conf, np.zeros(m, bool)])
        self.tree_cand = np.concatenate([self.tree_cand, np.full(m, -1, np.int64)])
        self.tree_cand_llr = np.concatenate([self.tree_cand_llr, np.zeros(m)])
        self.tree_alive = np.concatenate([self.tree_alive, np.ones(m, bool)])
        X = []
        P = []
        for q in range(k):
            x = np.zeros((m, self.d[q]))
            x[:, 0] = Z[new, q]
            X.append(x)
            P.append(np.broadcast_to(self._p0[q], (m, self.d[q], self.d[q])).copy())
        gids = gid0 + new
        ids = self.nodes.add(np.full(m, -1), self.frame, gids, np.concatenate(X, axis=1), 0.0, 0.0)
        recent = np.full((m, self.D), _NONE, np.int64)
        recent[:, -1] = gids
        n0 = _Hyps(
            node=ids,
            tree=trees,
            X=X,
            P=P,
            inc=np.zeros((m, self.N)),
            n_inc=np.zeros(m, np.int64),
            I_tot=np.zeros(m),
            llr=np.zeros(m),
            hits=np.ones(m, np.int64),
            miss=np.zeros(m, np.int64),
            t_last=np.full(m, t),
            pos_last=Z[new, :s].copy(),
            llr_last=np.zeros(m),
            node_last=ids,
            recent=recent,
            cur=gids,
            conf=np.zeros(m, bool),
            start=np.full(m, self.frame, np.int64),
        )
        if h.size == 0:
            return n0
        return _Hyps(
            **{  # type: ignore[arg-type]
                f: (
                    [np.concatenate([a, b]) for a, b in zip(v, getattr(n0, f))]
                    if isinstance(v, list)
                    else np.concatenate([v, getattr(n0, f)])
                )
                for f, v in h.__dict__.items()
            }
        )

    def _protected(self, c: _Hyps) -> np.ndarray:
        """Sequences kept whatever their rank (rule 3): per tree its best one and its best
        *exclusive* one, i.e. the best that shares none of its last D measurements with the best
        sequence of another tree. When two trees follow one target (close or crossing
        targets), each keeps the interpretation the other does not claim, and the final choice
        decides."""
        n = c.size
        protect = np.zeros(n, bool)
        order = np.lexsort((-c.llr, c.tree))
        first = order[np.r_[True, np.diff(c.tree[order]) != 0]]
        protect[first] = True
        g = c.recent[first].ravel()
        t = np.repeat(c.tree[first], self.D)
        ok = g >= 0
        g, t = g[ok], t[ok]
        if not len(g):
            return protect
        srt = np.argsort(g, kind="stable")
        g, t = g[srt], t[srt]
        # a measurement claimed by the bests of two trees belongs to neither
        dupl = np.r_[g[1:] == g[:-1], False] | np.r_[False, g[1:] == g[:-1]]
        t = np.where(dupl, -1, t)
        pos = np.minimum(np.searchsorted(g, c.recent), len(g) - 1)
        claimed = (g[pos] == c.recent) & (c.recent >= 0)
        conflict = (claimed & (t[pos] != c.tree[:, None])).any(1)
        ex = np.flatnonzero(~conflict)
        if len(ex):
            o = ex[np.lexsort((-c.llr[ex], c.tree[ex]))]
            protect[o[np.r_[True, np.diff(c.tree[o]) != 0]]] = True
        return protect

    def _greedy(self, h: _Hyps) -> np.ndarray:
        """Current global answer: confirmed sequences in decreasing score, at most one per tree,
        none sharing one of its last D measurements with a sequence taken before."""
        idx = np.flatnonzero(h.conf)
        if not len(idx):
            return idx
        idx = idx[np.argsort(-h.llr[idx], kind="stable")]
        trees: set = set()
        meas: set = set()
        out = []
        for i in idx:
            tr = int(h.tree[i])
            m = h.recent[i]
            m = m[m >= 0].tolist()
            if tr in trees or any(x in meas for x in m):
                continue
            trees.add(tr)
            meas.update(m)
            out.append(i)
        return np.array(out, dtype=np.int64)

    def _online_answer(self, h: _Hyps, t: float, gid0: int) -> None:
        """Per-frame online answer (``tracks(online=True)``): the greedy global answer."""
        for i in self._greedy(h):
            pos = [h.X[q][i, 0] for q in range(self.k)]
            self._online.append((self.frame, int(h.tree[i]), *pos, h.cur[i] < 0, float(h.llr[i])))

    def _compact(self) -> None:
        roots = [self.h.node, self.h.node_last, np.array([f for f, _ in self.finished], np.int64)]
        cand = self.tree_cand[self.tree_alive & (self.tree_cand >= 0)]
        roots.append(cand)
        remap = self.nodes.compact(np.concatenate(roots))
        self.h.node = remap[self.h.node]
        self.h.node_last = remap[self.h.node_last]
        self.finished = [(int(remap[f]), s) for f, s in self.finished]
        ok = self.tree_cand >= 0
        newc = np.full_like(self.tree_cand, -1)
        newc[ok & self.tree_alive] = remap[self.tree_cand[ok & self.tree_alive]]
        self.tree_cand = newc
        self._compact_at = max(200_000, 4 * self.nodes.n)

    # ---------------------------------------------------------------- answers
    def _candidates(self) -> list[tuple[int, float]]:
        """(leaf node, score) of every candidate of the final answer."""
        h = self.h
        out = list(self.finished)
        for i in np.flatnonzero(h.conf):
            out.append((int(h.node[i]), float(h.llr[i])))
        for tr in np.flatnonzero(self.tree_alive & self.tree_conf & (self.tree_cand >= 0)):
            out.append((int(self.tree_cand[tr]), float(self.tree_cand_llr[tr])))
        return out

    def select(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Final greedy choice (§3.3 step 3): (node chain, kept-measurement mask) pairs.

        ``selection="llr"``: candidates are taken in decreasing score. A candidate that shares at
        most ``max_shared`` measurements with sequences already taken is accepted with those
        frames turned into coasted ones (a crossing costs the later sequence a frame, not its
        identity); one that shares more is cut at the shared measurements and its pieces (with
        at least ``min_hits`` measurements, trailing misses cut, score = score gained over the
        piece) go back into the queue. ``"index_per_dof"``/``"pvalue"``: the literal rule,
        whole sequences, never two sharing a measurement.
        """
        import heapq
        from itertools import count

        tick = count()
        nodes = self.nodes
        heap = []
        for leaf, llr in self._candidates():
            chain = nodes.chain(leaf)
            hits = int((nodes.meas[chain] >= 0).sum())
            if hits < self.min_hits or llr < self.final_llr:
                continue
            if self.selection == "llr":
                key = -llr
            else:
                n_inc = max(1, min(hits - self.nu_max - 1, self.N))
                index = float(nodes.index[leaf])
                key = index / (self.k * n_inc)
                if self.selection == "pvalue":
                    key = -(1.0 - _chi2_cdf(index, self.k * n_inc))
            heap.append((key, -hits, next(tick), chain))
        heapq.heapify(heap)
        used: set = set()
        chosen = []
        while heap:
            key, nh, tie, chain = heapq.heappop(heap)
            m = nodes.meas[chain]
            shared = np.array([x >= 0 and int(x) in used for x in m], bool)
            n_sh = int(shared.sum())
            if n_sh == 0 or (
                self.selection == "llr"
                and n_sh <= self.max_shared
                and int((m >= 0).sum()) - n_sh >= self.min_hits
            ):
                used.update(int(x) for x in m[(m >= 0) & ~shared])
                chosen.append((chain, ~shared))
                continue
            if self.selection != "llr":
                continue
            bounds = np.r_[-1, np.flatnonzero(shared), len(chain)]
            for lo, hi in zip(bounds[:-1] + 1, bounds[1:]):
                piece = chain[lo:hi]
                if not len(piece):
                    continue
                pm = nodes.meas[piece]
                if hi < len(chain):  # cut trailing misses before the shared frame
                    last = np.flatnonzero(pm >= 0)
                    if not len(last):
                        continue
                    piece = piece[: last[-1] + 1]
                    pm = pm[: last[-1] + 1]
                hits = int((pm >= 0).sum())
                base = float(nodes.llr[chain[lo - 1]]) if lo > 0 else 0.0
                gain = float(nodes.llr[piece[-1]]) - base
                if hits >= self.min_hits and gain >= self.final_llr:
                    heapq.heappush(heap, (-gain, -hits, next(tick), piece))
        chosen.sort(key=lambda c: (int(nodes.frame[c[0][0]]), int(c[0][0])))
        return chosen

    def tracks(self, online: bool = False) -> pd.DataFrame:
        """Per-frame estimates of the chosen sequences, coasted frames included.

        Columns: frame, particle, the parameters (filtered estimates), their derivatives
        ``<name>_d1``…, ``detection`` (global detection id, −1 when coasted), ``coasted``,
        ``likelihood_index`` (sliding index I, §3.2) and ``score``. ``online=True`` gives the
        per-frame online answer instead (particle = track tree id).
        """
        if online:
            names = ["frame", "particle", *self.names, "coasted", "score"]
            return pd.DataFrame(self._online, columns=names)
        nodes = self.nodes
        cols: dict[str, list] = {"frame": [], "particle": []}
        chosen = self.select()
        chains = [c for c, _ in chosen]
        for pid, chain in enumerate(chains):
            cols["frame"].append(nodes.frame[chain])
            cols["particle"].append(np.full(len(chain), pid))
        data = {
            "frame": np.concatenate(cols["frame"]) if chains else np.zeros(0, np.int64),
            "particle": np.concatenate(cols["particle"]) if chains else np.zeros(0, np.int64),
        }
        allc = np.concatenate(chains) if chains else np.zeros(0, np.int64)
        stt = nodes.state[allc]
        for q, name in enumerate(self.names):
            data[name] = stt[:, self.off[q]]
        for q, name in enumerate(self.names):
            for j in range(1, self.d[q]):
                data[f"{name}_d{j}"] = stt[:, self.off[q] + j]
        kept = np.concatenate([k for _, k in chosen]) if chosen else np.zeros(0, bool)
        data["detection"] = np.where(kept, nodes.meas[allc], -1)
        data["coasted"] = data["detection"] < 0
        data["likelihood_index"] = nodes.index[allc]
        data["score"] = nodes.llr[allc]
        return pd.DataFrame(data)

    def detection_frame(self, gid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(frame, row within frame) of global detection ids."""
        offs = np.cumsum([0] + [len(z) for z in self._meas])
        f = np.searchsorted(offs, gid, side="right") - 1
        return f, gid - offs[f]


def link(
    detections: pd.DataFrame,
    *,
    measurement_std,
    process_std,
    diffusion_std=0.0,
    max_speed: float = 6.0,
    confidence: float = 0.999,
    memory: int = 4,
    max_misses: int = 3,
    dt: float = 1.0,
    features: Sequence[str] = (),
    pos_columns: Sequence[str] = ("x", "y"),
    t_column: str = "frame",
    keep_unlinked: bool = False,
    **kwargs,
) -> pd.DataFrame:
    """trackpy-style linking with the branching tracker (twin of ``kalmanfield.tracking.link``
    given its noise levels and largest speed: no pilot run, no estimate).

    ``detections`` has columns ``t_column``, the ``pos_columns`` (+ ``features``); returns its
    rows on a track (all of them with ``keep_unlinked``, the others with particle −1) with a
    ``particle`` column. ``measurement_std``/``process_std``/``diffusion_std`` are scalars or
    one value per column (positions then features); extra keyword arguments go to
    ``BranchingTracker``.
    """
    cols = [*pos_columns, *features]
    df = detections.reset_index(drop=True)
    frame_no = df[t_column].to_numpy().astype(np.int64)
    if kwargs.get("clutter_density") is None and len(df):
        # detections per frame over the bounding box of the columns (sides ≥ 1), whole table
        values = df[cols].to_numpy(dtype=float)
        rate = max(len(df) / (int(frame_no.max()) - int(frame_no.min()) + 1), 1.0)
        sides = np.maximum(values.max(axis=0) - values.min(axis=0), 1.0)
        kwargs["clutter_density"] = float(rate / np.prod(sides))
    tr = BranchingTracker(
        len(cols),
        process_std=process_std,
        diffusion_std=diffusion_std,
        measurement_std=measurement_std,
        max_speed=max_speed,
        confidence=confidence,
        memory=memory,
        max_misses=max_misses,
        dt=dt,
        n_spatial=len(pos_columns),
        names=cols,
        **kwargs,
    )
    frames = np.sort(np.unique(frame_no))
    rows = []
    for f in range(int(frames.min()), int(frames.max()) + 1) if len(frames) else []:
        sel = np.flatnonzero(frame_no == f)
        rows.append(sel)
        tr.update(df.loc[sel, cols].to_numpy(dtype=float), time=(f - frames.min()) * dt)
    gid_to_row = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    particle = np.full(len(df), -1, np.int64)
    t = tr.tracks()
    hit = t["detection"].to_numpy() >= 0
    particle[gid_to_row[t["detection"].to_numpy()[hit]]] = t["particle"].to_numpy()[hit]
    out = detections.copy()
    out["particle"] = particle
    return out if keep_unlinked else out[particle >= 0]
