"""Plain-NumPy twin of stage 2 of the detector (``rust/src/extended``; method page *Extended
objects*, §3.4): same rules, same loop order and tie-breaks, so both give the same answer.

A configuration is a dict with the fields of the Rust ``GroupConfig`` (order, dt,
position_std, process_std, amplitude_std, log_area_std, feature_drift, confidence, memory,
initial_speed_std, gate_margin, min_speed, velocity_tolerance, cohesion, max_misses,
seed_groups). A frame's segments are an (m, 8) array: x, y, amplitude, area, bbox x0, y0,
x1, y1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..tracking.branching import chi2_quantile

__all__ = ["GroupTracker", "assign"]

DIM = 3
#: members covering this fraction of the group's area are the whole object
COMPLETE = 0.9
#: per frame the group's area decays by this factor towards its members'
AREA_DECAY = 0.98
#: rounding slack (pixels) when box widths are compared
WIDTH_TOLERANCE = 1e-9


def assign(sequence: np.ndarray, segment: np.ndarray, index: np.ndarray) -> list[int]:
    """Steps 5–6: positions of the chosen variants, best first (smallest index, ties to the
    lower sequence then segment), never two sharing a sequence or a segment."""
    order = sorted(range(len(index)), key=lambda k: (index[k], sequence[k], segment[k]))
    used_seq: set[int] = set()
    used_seg: set[int] = set()
    chosen = []
    for k in order:
        if sequence[k] not in used_seq and segment[k] not in used_seg:
            used_seq.add(int(sequence[k]))
            used_seg.add(int(segment[k]))
            chosen.append(k)
    return chosen


def motion(order: int, tau: float, sigma: float) -> tuple[np.ndarray, np.ndarray]:
    """F (Taylor) and Q = σ² g gᵀ, g_i = τ^(ν−i)/(ν−i)! (the model of §3.5), padded to 3×3."""
    d = order + 1
    F = np.zeros((DIM, DIM))
    g = np.zeros(DIM)
    for i in range(d):
        for j in range(i, d):
            F[i, j] = tau ** (j - i) / math.factorial(j - i)
        g[i] = tau ** (order - i) / math.factorial(order - i)
    return F, sigma * sigma * np.outer(g, g)


@dataclass
class Sequence:
    id: int
    state: np.ndarray  # (2, 3)
    cov: np.ndarray  # (2, 3, 3)
    feature: np.ndarray  # (2,)
    feature_var: np.ndarray  # (2,)
    bbox: np.ndarray  # (4,): box of its last segment
    length: int = 1
    window: list = field(default_factory=list)
    segment: int | None = None
    offset: np.ndarray | None = None  # centroid minus the group's centre, while a member


@dataclass
class Group:
    id: int
    shared: np.ndarray  # (2, 3): column 0 unused
    sequences: list = field(default_factory=list)
    bbox: np.ndarray = field(default_factory=lambda: np.zeros(4))
    misses: int = 0
    frames_detected: int = 0
    held: int = 0
    area: float = 0.0  # members' area the object is known to cover


def _features(z: np.ndarray) -> np.ndarray:
    return np.array([z[2], math.log(z[3])])


def _covers_half(a: np.ndarray, b: np.ndarray) -> bool:
    """Whether box a covers at least half of box b's area (x0, y0, x1, y1)."""
    w = min(a[2], b[2]) - max(a[0], b[0])
    h = min(a[3], b[3]) - max(a[1], b[1])
    return bool(w >= 0.0 and h >= 0.0 and w * h >= 0.5 * (b[2] - b[0]) * (b[3] - b[1]))


def _propagate(F: np.ndarray, P: np.ndarray, Q: np.ndarray, d: int) -> np.ndarray:
    return F[:d, :d] @ P[:d, :d] @ F[:d, :d].T + Q[:d, :d]


class GroupTracker:
    """Stage 2 frame by frame; :meth:`step` returns (segment_group, segment_sequence,
    segment_member, groups, merged) with groups an (G, 7) array id, x, y, vx, vy, members,
    frames_detected and merged the (absorbed, into) pairs — the Rust ``FrameAnswer``."""

    def __init__(self, config: dict[str, Any]) -> None:
        self.c = dict(config)
        c = self.c
        self.F, self.Q = motion(c["order"], c["dt"], c["process_std"])
        most = c["memory"] * 4
        self.alpha = [math.inf] + [
            chi2_quantile(c["confidence"], dof) for dof in range(1, most + 1)
        ]
        self.groups: list[Group] = []
        self.next_group = 0
        self.next_sequence = 0
        #: ids of the groups hidden in the last frame (the Rust answer's ``hidden``)
        self.hidden: list[int] = []

    def seed(self, segments: np.ndarray, vx: float, vy: float, length: int = 1) -> int:
        """A group at `segments` with the shared velocity (vx, vy); its sequences count
        `length` observations (stage 1's), features with one observation's variance."""
        z_all = np.asarray(segments, dtype=float).reshape(-1, 8)
        shared = np.zeros((2, DIM))
        shared[:, 1] = [vx, vy]
        g = Group(self.next_group, shared, bbox=z_all[0, 4:8].copy() if len(z_all) else np.zeros(4))
        self.next_group += 1
        self.groups.append(g)
        for z in z_all:
            s = self._start(z, g.shared)
            if length > 1:
                s.length = length
                s.feature_var = self._feature_std() ** 2
            g.sequences.append(s)
            g.bbox = self._union(g.bbox, z[4:8])
        return g.id

    # -- one sequence ------------------------------------------------------------------------
    def _feature_std(self) -> np.ndarray:
        return np.array([self.c["amplitude_std"], self.c["log_area_std"]])

    def _start(self, z: np.ndarray, shared: np.ndarray) -> Sequence:
        c, d = self.c, self.c["order"] + 1
        state = shared.copy()
        state[:, 0] = z[:2]
        cov = np.zeros((2, DIM, DIM))
        cov[:, 0, 0] = c["position_std"] ** 2
        for k in range(1, d):
            cov[:, k, k] = (c["initial_speed_std"] / c["dt"] ** (k - 1)) ** 2
        s = Sequence(self.next_sequence, state, cov, _features(z), np.zeros(2), z[4:8].copy())
        self.next_sequence += 1
        return s

    def _partial_var(self, s: Sequence, z: np.ndarray) -> np.ndarray:
        """(Δ/2)² per axis where the box kept one edge (±1 px) of the last one moved by the
        sequence's velocity and its extent changed by Δ; 0 elsewhere."""
        shift = s.state[:, 1] * self.c["dt"]
        lo = z[4:6] - s.bbox[:2] - shift
        hi = z[6:8] - s.bbox[2:] - shift
        kept = np.minimum(np.abs(lo), np.abs(hi)) <= 1.0
        return np.where(kept, (0.5 * (hi - lo)) ** 2, 0.0)

    def _coast(self, s: Sequence) -> None:
        """Prediction without update (own derivatives); the box moves by the velocity."""
        d = self.c["order"] + 1
        shift = s.state[:, 1] * self.c["dt"]
        s.bbox = s.bbox + np.concatenate([shift, shift])
        for axis in range(2):
            s.state[axis, :d] = self.F[:d, :d] @ s.state[axis, :d]
            s.cov[axis, :d, :d] = _propagate(self.F, s.cov[axis], self.Q, d)

    def _joined(self, s: Sequence) -> bool:
        return s.length > self.c["order"]

    def _predict(self, s: Sequence, shared: np.ndarray):
        c, d = self.c, self.c["order"] + 1
        centre, var = np.zeros(2), np.zeros(2)
        for axis in range(2):
            x = shared[axis].copy()
            x[0] = s.state[axis, 0]
            centre[axis] = (self.F[:d, :d] @ x[:d])[0]
            var[axis] = _propagate(self.F, s.cov[axis], self.Q, d)[0, 0] + c["position_std"] ** 2
        fvar = None
        if self._joined(s):
            fvar = s.feature_var + (1.0 + c["feature_drift"] ** 2) * self._feature_std() ** 2
        kept = s.window[1:] if len(s.window) >= c["memory"] else s.window
        return centre, var, fvar, sum(v for v, _ in kept), sum(k for _, k in kept)

    def _increment(self, s: Sequence, pred, z: np.ndarray) -> tuple[float, int]:
        centre, var, fvar, _, _ = pred
        value = float(np.sum((z[:2] - centre) ** 2 / (var + self._partial_var(s, z))))
        dof = 2
        if fvar is not None:
            value += float(np.sum((_features(z) - s.feature) ** 2 / fvar))
            dof += 2
        return value, dof

    def _update(self, s: Sequence, z: np.ndarray, increment: tuple[float, int]) -> None:
        c, d = self.c, self.c["order"] + 1
        r = c["position_std"] ** 2 + self._partial_var(s, z)
        for axis in range(2):
            x = self.F[:d, :d] @ s.state[axis, :d]
            P = _propagate(self.F, s.cov[axis], self.Q, d)
            dvar = P[0, 0] + r[axis]
            s.state[axis, :d] = x + P[:, 0] / dvar * (z[axis] - x[0])
            s.cov[axis, :d, :d] = P - np.outer(P[:, 0], P[0, :]) / dvar
        f, std = _features(z), self._feature_std()
        if self._joined(s):
            prior = s.feature_var + (c["feature_drift"] * std) ** 2
            gain = prior / (prior + std * std)
            s.feature = s.feature + gain * (f - s.feature)
            s.feature_var = (1.0 - gain) * prior
        else:
            s.feature = s.feature + f
            if s.length + 1 > c["order"]:
                n = s.length + 1
                s.feature = s.feature / n
                s.feature_var = std * std / n
        if len(s.window) >= c["memory"]:
            s.window.pop(0)
        s.window.append(increment)
        s.bbox = z[4:8].copy()
        s.length += 1

    # -- groups ------------------------------------------------------------------------------
    def _refresh_shared(self, g: Group) -> None:
        c = self.c
        previous = g.shared[:, 1].copy()
        near = [
            s
            for s in g.sequences
            if math.hypot(*(s.state[:, 1] - previous)) <= c["velocity_tolerance"]
        ]
        chosen = near or g.sequences
        restarted = all(s.length <= c["order"] + 1 for s in chosen)
        if not chosen or (restarted and g.frames_detected > 0):
            return  # the object's velocity outlives its fragments' restarted sequences
        for k in range(1, c["order"] + 1):
            # each sequence weighted by its precision 1/P_kk
            w = np.array([1.0 / np.maximum(s.cov[:, k, k], np.finfo(float).tiny) for s in chosen])
            x = np.array([s.state[:, k] for s in chosen])
            g.shared[:, k] = (w * x).sum(axis=0) / w.sum(axis=0)

    def _is_member(self, g: Group, s: Sequence) -> bool:
        c, v = self.c, s.state[:, 1]
        return (
            s.segment is not None
            and s.length > c["order"] + 1
            and math.hypot(v[0], v[1]) > c["min_speed"]
            and math.hypot(*(v - g.shared[:, 1])) <= c["velocity_tolerance"]
        )

    def _hold(self, g: Group, seen: np.ndarray, predicted: np.ndarray) -> None:
        """A box narrower or lower than the predicted one: a fragment is missing, the box
        keeps the union of both (at most N frames in a row)."""
        smaller = (
            seen[2] - seen[0] <= predicted[2] - predicted[0] - 1.0 + WIDTH_TOLERANCE
            or seen[3] - seen[1] <= predicted[3] - predicted[1] - 1.0 + WIDTH_TOLERANCE
        )
        if smaller and g.held < self.c["memory"]:
            g.bbox, g.held = self._union(seen, predicted), g.held + 1
        else:
            g.bbox, g.held = seen, 0

    @staticmethod
    def _union(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.array([min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])])

    # -- one frame ---------------------------------------------------------------------------
    def step(self, segments: np.ndarray):
        z_all = np.asarray(segments, dtype=float).reshape(-1, 8)
        m, c = len(z_all), self.c
        seg_group, seg_seq, seg_member = np.full(m, -1), np.full(m, -1), np.zeros(m, bool)
        predicted = {
            g.id: g.bbox + np.array([g.shared[0, 1], g.shared[1, 1]] * 2) * c["dt"]
            for g in self.groups
        }
        # steps 5-6
        flat: list[tuple[int, int]] = []
        seqs: list[int] = []
        segs: list[int] = []
        index: list[float] = []
        incs: list[tuple[float, int]] = []
        for gi, g in enumerate(self.groups):
            for si, s in enumerate(g.sequences):
                pred = self._predict(s, g.shared)
                for r in range(m):
                    value, dof = self._increment(s, pred, z_all[r])
                    total = pred[3] + value
                    if total <= self.alpha[pred[4] + dof]:
                        seqs.append(len(flat))
                        segs.append(r)
                        index.append(total)
                        incs.append((value, dof))
                flat.append((gi, si))
        chosen = assign(np.array(seqs), np.array(segs), np.array(index))
        merged_segment, hidden = self._occlusions(
            z_all, [(flat[seqs[k]][0], segs[k]) for k in chosen]
        )
        self.hidden = [g.id for g, h in zip(self.groups, hidden) if h]
        # steps 7-8
        for g in self.groups:
            for s in g.sequences:
                s.segment = None
        for k in chosen:
            gi, si = flat[seqs[k]]
            s = self.groups[gi].sequences[si]
            if merged_segment[segs[k]]:
                self._coast(s)
            else:
                self._update(s, z_all[segs[k]], incs[k])
            s.segment = segs[k]
        for g, h in zip(self.groups, hidden):
            if h:
                for s in g.sequences:
                    self._coast(s)
            else:
                g.sequences = [s for s in g.sequences if s.segment is not None]
        for g in self.groups:
            if all(s.segment is None for s in g.sequences):
                g.misses += 1
                v = g.shared[:, 1]
                g.bbox = g.bbox + np.array([v[0], v[1], v[0], v[1]]) * c["dt"]
                continue
            g.misses = 0
            moved = g.bbox + np.array([g.shared[0, 1], g.shared[1, 1]] * 2) * c["dt"]
            self._refresh_shared(g)
            boxes = [s.bbox for s in g.sequences if s.segment is not None]
            box = boxes[0]
            for b in boxes[1:]:
                box = self._union(box, b)
            self._hold(g, box, moved)
        hidden_limit = max(c["max_misses"], 2 * c["memory"])
        self.groups = [
            g
            for g, h in zip(self.groups, hidden)
            if g.misses <= (hidden_limit if h else c["max_misses"])
        ]
        self._split(z_all)
        self._start_new(z_all, seg_group, seg_seq, predicted)
        merged = self._merge()
        groups = self._report(z_all, seg_group, seg_seq, seg_member)
        return seg_group, seg_seq, seg_member, groups, merged

    def _occlusions(self, z_all, chosen: list[tuple[int, int]]) -> tuple[list[bool], list[bool]]:
        """(merged per segment, hidden per group): an object (detected in N frames at least,
        moving) without a confirmed sequence, hidden by a segment confirmed (chosen: (group,
        segment) pairs) by a group of another velocity: a sequence's predicted centroid lies in
        the segment's box or the box covers half of the group's predicted box."""
        c = self.c
        merged = [False] * len(z_all)
        hidden = [False] * len(self.groups)
        confirmed = {gi for gi, _ in chosen}

        def is_object(g: Group) -> bool:  # detected in N frames at least, moving
            v = g.shared[:, 1]
            return g.frames_detected >= c["memory"] and math.hypot(v[0], v[1]) > c["min_speed"]

        for b, g in enumerate(self.groups):
            if b in confirmed or not is_object(g):
                continue
            v = g.shared[:, 1]
            centres = [self._predict(s, g.shared)[0] for s in g.sequences]
            predicted = g.bbox + np.array([v[0], v[1]] * 2) * c["dt"]
            for a, r in chosen:
                if math.hypot(*(self.groups[a].shared[:, 1] - v)) <= c["velocity_tolerance"]:
                    continue
                box = z_all[r, 4:8]
                inside = any(box[0] <= x <= box[2] and box[1] <= y <= box[3] for x, y in centres)
                if inside or _covers_half(box, predicted):
                    merged[r] = True
                    hidden[b] = True
        return merged, hidden

    def _split(self, z_all) -> None:
        c = self.c
        leaving: list[Sequence] = []
        for g in self.groups:
            shared = g.shared[:, 1].copy()
            stay: list[Sequence] = []
            for s in g.sequences:
                near = math.hypot(*(s.state[:, 1] - shared)) <= c["velocity_tolerance"]
                (stay if s.length <= c["order"] + 1 or near else leaving).append(s)
            g.sequences = stay
        for s in leaving:
            s.offset = None
            shared = s.state.copy()
            shared[:, 0] = 0.0
            if s.segment is None:
                box = np.array([s.state[0, 0], s.state[1, 0]] * 2)
            else:
                box = z_all[s.segment, 4:8].copy()
            self.groups.append(Group(self.next_group, shared, [s], box))
            self.next_group += 1

    def _start_new(self, z_all, seg_group, seg_seq, predicted) -> None:
        c = self.c
        used = {s.segment for g in self.groups for s in g.sequences}
        old = len(self.groups)
        margin = c["gate_margin"]
        for r, z in enumerate(z_all):
            if r in used:
                continue
            best = None
            for gi, g in enumerate(self.groups):
                b = g.bbox
                if g.id in predicted:
                    b = self._union(b, predicted[g.id])
                if (
                    b[0] - margin <= z[0] <= b[2] + margin
                    and b[1] - margin <= z[1] <= b[3] + margin
                ):
                    o = g.bbox
                    centre = np.array([0.5 * (o[0] + o[2]), 0.5 * (o[1] + o[3])])
                    dist = math.hypot(*(centre - z[:2]))
                    if best is None or dist < best[0]:
                        best = (dist, gi)
            if best is not None:
                gi = best[1]
            elif c["seed_groups"]:
                self.groups.append(Group(self.next_group, np.zeros((2, DIM)), bbox=z[4:8].copy()))
                self.next_group += 1
                gi = len(self.groups) - 1
            else:
                continue
            g = self.groups[gi]
            g.misses = 0
            s = self._start(z, g.shared)
            s.segment = r
            g.sequences.append(s)
            if gi >= old:
                g.bbox = self._union(g.bbox, z[4:8])
            seg_group[r], seg_seq[r] = g.id, s.id

    def _merge(self) -> list[tuple[int, int]]:
        c = self.c
        merged = []

        def mature(g: Group) -> bool:
            return any(s.length > c["order"] + 1 for s in g.sequences)

        def gap(a: np.ndarray, b: np.ndarray) -> float:
            return max(b[0] - a[2], a[0] - b[2], b[1] - a[3], a[1] - b[3], 0.0)

        def extent(b: np.ndarray) -> float:
            return max(b[2] - b[0], b[3] - b[1]) + 1.0

        i = 0
        while i < len(self.groups):
            j = i + 1
            while j < len(self.groups):
                a, b = self.groups[i], self.groups[j]
                agree = math.hypot(*(a.shared[:, 1] - b.shared[:, 1])) <= c["velocity_tolerance"]
                reach = max(c["gate_margin"], c["cohesion"] * min(extent(a.bbox), extent(b.bbox)))
                if gap(a.bbox, b.bbox) <= reach and mature(a) and mature(b) and agree:
                    self.groups.pop(j)
                    merged.append((b.id, a.id))
                    na, nb = len(a.sequences), len(b.sequences)
                    a.shared[:, 1:] = (na * a.shared[:, 1:] + nb * b.shared[:, 1:]) / (na + nb)
                    keep_b = a.area == 0.0 and b.area > 0.0
                    for s in a.sequences if keep_b else b.sequences:
                        s.offset = None
                    if keep_b:
                        a.area = b.area
                    a.sequences.extend(b.sequences)
                    a.bbox = self._union(a.bbox, b.bbox)
                    a.frames_detected = max(a.frames_detected, b.frames_detected)
                    a.misses = min(a.misses, b.misses)
                    a.held = min(a.held, b.held)
                else:
                    j += 1
            i += 1
        return merged

    @staticmethod
    def _member_centre(g: Group, members: list[Sequence], z_all: np.ndarray) -> np.ndarray:
        """Members covering the object: their area-weighted centroid, offsets recorded; a
        fragment missing: the members' centroids minus their offsets."""
        area = np.array([z_all[s.segment, 3] for s in members])
        pos = np.array([s.state[:, 0] for s in members])
        total = float(area.sum())
        complete = total >= COMPLETE * g.area
        g.area = max(total, AREA_DECAY * g.area)
        known = [k for k, s in enumerate(members) if s.offset is not None]
        if not complete and known:
            off = np.array([members[k].offset for k in known])
            centre = (area[known, None] * (pos[known] - off)).sum(axis=0) / area[known].sum()
        else:
            centre = (area[:, None] * pos).sum(axis=0) / total
        for s in members:
            if complete or s.offset is None:
                s.offset = s.state[:, 0] - centre
        return centre

    def _report(self, z_all, seg_group, seg_seq, seg_member) -> np.ndarray:
        rows = []
        for g in self.groups:
            members = []
            ax = ay = aw = 0.0
            for s in g.sequences:
                if s.segment is None:
                    continue
                r = s.segment
                area = z_all[r, 3]
                seg_group[r], seg_seq[r] = g.id, s.id
                ax += area * s.state[0, 0]
                ay += area * s.state[1, 0]
                aw += area
                if self._is_member(g, s):
                    seg_member[r] = True
                    members.append(s)
            if members:
                g.frames_detected += 1
                centre = self._member_centre(g, members, z_all)
            elif aw > 0:
                centre = np.array([ax / aw, ay / aw])
            else:
                centre = np.array([0.5 * (g.bbox[0] + g.bbox[2]), 0.5 * (g.bbox[1] + g.bbox[3])])
            rows.append(
                [g.id, *centre, g.shared[0, 1], g.shared[1, 1], len(members), g.frames_detected]
            )
        return np.array(rows, dtype=float).reshape(-1, 7)
