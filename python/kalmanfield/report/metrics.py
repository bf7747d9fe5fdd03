"""The demo's scores against the truth: IDF1 and MOTA (py-motmetrics when installed, else a
plain identity-match count), the probability of correct detection per frame, change-point
detection delays, the type confusion matrix and the extended objects' detection."""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass

import numpy as np
import pandas as pd

#: a track point is on a target when within this distance of it (px)
GATE = 2.0


def _pairs_within(truth: pd.DataFrame, hyp: pd.DataFrame, gate: float):
    """Per frame: (frame, truth ids, hyp ids, distance matrix with inf beyond the gate)."""
    by_frame = dict(tuple(hyp.groupby("frame")))
    for frame, gt in truth.groupby("frame"):
        h = by_frame.get(frame)
        g_xy = gt[["x", "y"]].to_numpy()
        h_xy = np.zeros((0, 2)) if h is None else h[["x", "y"]].to_numpy()
        d = np.hypot(*(g_xy[:, None, :] - h_xy[None, :, :]).transpose(2, 0, 1))
        d[d > gate] = np.inf
        ids = np.zeros(0, np.int64) if h is None else h["particle"].to_numpy()
        yield frame, gt["particle"].to_numpy(), ids, d


def _greedy(d: np.ndarray) -> list[tuple[int, int]]:
    """One-to-one pairs (i, j) of finite d, closest first."""
    pairs, used_i, used_j = [], set(), set()
    for flat in np.argsort(d, axis=None):
        i, j = np.unravel_index(flat, d.shape)
        if not np.isfinite(d[i, j]):
            break
        if i not in used_i and j not in used_j:
            pairs.append((int(i), int(j)))
            used_i.add(i)
            used_j.add(j)
    return pairs


def identity_scores(truth: pd.DataFrame, hyp: pd.DataFrame, gate: float = GATE) -> dict:
    """IDF1, MOTA, ID switches, misses and false positives of the tracks `hyp` (frame,
    particle, x, y) against `truth`, and which track follows each target.

    With py-motmetrics installed the scores are its own; otherwise they are counted here:
    per frame the targets and track points are paired greedily, closest first, within
    `gate` (MOTA = 1 − (misses + false positives + switches) / targets), and IDF1 pairs
    targets with tracks one to one, greedily by the number of frames they share (a lower
    bound of the optimal assignment that motmetrics makes)."""
    shared: dict[tuple[int, int], int] = {}
    for _, gt_ids, h_ids, d in _pairs_within(truth, hyp, gate):
        for i, j in zip(*np.nonzero(np.isfinite(d))):
            key = (int(gt_ids[i]), int(h_ids[j]))
            shared[key] = shared.get(key, 0) + 1
    follows: dict[int, int] = {}
    used: set[int] = set()
    idtp = 0
    for (target, track), count in sorted(shared.items(), key=lambda kv: -kv[1]):
        if target not in follows and track not in used:
            follows[target], idtp = track, idtp + count
            used.add(track)
    scores = (
        _motmetrics(truth, hyp, gate)
        if importlib.util.find_spec("motmetrics")
        else _counted(truth, hyp, gate, idtp)
    )
    return {**scores, "follows": follows}


def _counted(truth: pd.DataFrame, hyp: pd.DataFrame, gate: float, idtp: int) -> dict:
    misses = false_positives = switches = 0
    last: dict[int, int] = {}
    for _, gt_ids, h_ids, d in _pairs_within(truth, hyp, gate):
        pairs = _greedy(d)
        misses += len(gt_ids) - len(pairs)
        false_positives += len(h_ids) - len(pairs)
        for i, j in pairs:
            target, track = int(gt_ids[i]), int(h_ids[j])
            switches += target in last and last[target] != track
            last[target] = track
    n_truth = len(truth)
    # track points in frames without any target are false positives too
    false_positives += int((~hyp["frame"].isin(truth["frame"])).sum())
    return {
        "idf1": 2 * idtp / (n_truth + len(hyp)) if n_truth + len(hyp) else 1.0,
        "mota": 1 - (misses + false_positives + switches) / n_truth if n_truth else 1.0,
        "switches": switches,
        "misses": misses,
        "false_positives": false_positives,
        "scored_by": "kalmanfield (greedy identity matching; py-motmetrics not installed)",
    }


def _motmetrics(truth: pd.DataFrame, hyp: pd.DataFrame, gate: float) -> dict:
    import motmetrics as mm

    acc = mm.MOTAccumulator(auto_id=False)
    seen = set()
    for frame, gt_ids, h_ids, d in _pairs_within(truth, hyp, gate):
        acc.update(gt_ids, h_ids, np.where(np.isfinite(d), d**2, np.nan), frameid=int(frame))
        seen.add(frame)
    for frame, h in hyp[~hyp["frame"].isin(seen)].groupby("frame"):
        acc.update([], h["particle"].to_numpy(), np.zeros((0, len(h))), frameid=int(frame))
    names = ["idf1", "mota", "num_switches", "num_misses", "num_false_positives"]
    row = mm.metrics.create().compute(acc, metrics=names, name="demo").iloc[0]
    return {
        "idf1": float(row["idf1"]),
        "mota": float(row["mota"]),
        "switches": int(row["num_switches"]),
        "misses": int(row["num_misses"]),
        "false_positives": int(row["num_false_positives"]),
        "scored_by": f"py-motmetrics {mm.__version__}",
    }


def detection_probability(
    truth: pd.DataFrame, hyp: pd.DataFrame, n_frames: int, gate: float = GATE
) -> np.ndarray:
    """P_o per frame: the fraction of the targets in the frame with a track point within
    `gate` (paired one to one)."""
    p = np.full(n_frames, np.nan)
    for frame, gt_ids, _, d in _pairs_within(truth, hyp, gate):
        p[int(frame)] = len(_greedy(d)) / len(gt_ids)
    return p


@dataclass
class ChangeScores:
    """Change-point detection on the tracks: per true change, the delay (frames from the
    change to the first alarm on the track following the target, NaN if none within
    `window`), and the false alarms (alarms not within `window` after a true change)."""

    delays: pd.DataFrame
    false_alarms: int
    track_frames: int
    window: int


def change_scores(
    alarms: dict[int, np.ndarray],
    lengths: dict[int, int],
    changes: pd.DataFrame,
    follows: dict[int, int],
    window: int = 10,
) -> ChangeScores:
    """Scores the alarm frames of every track (`alarms`: track → frames) against the true
    `changes` (particle, frame) of the targets the tracks follow."""
    rows, explained = [], {track: np.zeros(len(a), bool) for track, a in alarms.items()}
    for change in changes.itertuples():
        track = follows.get(int(change.particle))
        delay = np.nan
        if track is not None and track in alarms:
            after = (alarms[track] >= change.frame) & (alarms[track] <= change.frame + window)
            explained[track] |= after
            if after.any():
                delay = float(alarms[track][after].min() - change.frame)
        rows.append({"particle": int(change.particle), "frame": int(change.frame), "delay": delay})
    false = sum(int((~e).sum()) for e in explained.values())
    table = pd.DataFrame(rows, columns=["particle", "frame", "delay"])
    return ChangeScores(table, false, int(sum(lengths.values())), window)


def type_confusion_matrix(
    decided: pd.DataFrame, truth: pd.DataFrame, follows: dict[int, int], names: list[str]
) -> pd.DataFrame:
    """Counts of the targets by true type (rows) and the type decided for the track that
    follows them (columns, "undecided" and "not tracked" included)."""
    true_type = truth.groupby("particle")["type"].first()
    by_track = decided.set_index("particle")["type"]
    columns = [*names, "undecided", "not tracked"]
    table = pd.DataFrame(0, index=names, columns=columns)
    for target, kind in true_type.items():
        track = follows.get(int(target))
        got = by_track.get(track, "not tracked") if track is not None else "not tracked"
        table.loc[names[int(kind)], got] += 1
    return table


def farther(hyp: pd.DataFrame, centres: pd.DataFrame, radius: float) -> np.ndarray:
    """True for the rows of `hyp` (frame, x, y, …) farther than `radius` from every row of
    `centres` (frame, x, y) in the same frame."""
    keep = np.ones(len(hyp), bool)
    frame, xy = hyp["frame"].to_numpy(), hyp[["x", "y"]].to_numpy()
    for f, c in centres.groupby("frame"):
        rows = np.flatnonzero(frame == f)
        d = np.hypot(*(xy[rows, None, :] - c[["x", "y"]].to_numpy()[None]).transpose(2, 0, 1))
        keep[rows] = (d > radius).all(axis=1)
    return keep


def extended_scores(truth: pd.DataFrame, tracks: list[pd.DataFrame], gate: float) -> pd.DataFrame:
    """Per true extended object (`truth`: frame, object, x, y, vx, vy): its frames, P_o (the
    fraction of them in which a detected object's centre lies within `gate`), how many
    detected objects do (1: one object follows it throughout; more: it was fragmented), and
    which one does longest (`best`, its index in `tracks`: each detected object's centre
    track, frame, x, y, vx, vy; −1 for none), for how many frames, and its mean velocity
    beside the truth."""
    empty = pd.DataFrame({c: np.zeros(0) for c in ("x", "y", "vx", "vy")}).assign(
        frame=np.zeros(0, np.int64), rank=np.zeros(0, np.int64)
    )
    found = pd.concat([empty] + [t.assign(rank=k) for k, t in enumerate(tracks)], ignore_index=True)
    rows = []
    for obj, t in truth.groupby("object"):
        pairs = t.merge(found, on="frame", suffixes=("", "_found"))
        near = pairs[np.hypot(pairs.x - pairs.x_found, pairs.y - pairs.y_found) <= gate]
        counts = near.groupby("rank").size()
        best = near[near["rank"] == counts.idxmax()] if len(counts) else near
        rows.append(
            {
                "object": int(obj),
                "frames": len(t),
                "P_o": near["frame"].nunique() / len(t),
                "detected_as": len(counts),
                "longest": int(counts.max()) if len(counts) else 0,
                "best": int(counts.idxmax()) if len(counts) else -1,
                "v_true": (float(t.vx.mean()), float(t.vy.mean())),
                "v_found": (float(best.vx_found.mean()), float(best.vy_found.mean()))
                if len(best)
                else None,
            }
        )
    return pd.DataFrame(rows)
