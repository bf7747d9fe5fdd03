"""A tracker's output (frame, particle, x, y) as a batch of trajectories, one per particle,
each starting at its own first frame; the frames it skips are NaN rows (missed), and frames
after its last are NaN too (prediction only: they change neither likelihood nor decision)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from .._validation import real_array


def tracks_to_batch(
    tracks: pd.DataFrame, columns: Sequence[str]
) -> tuple[np.ndarray, pd.DataFrame]:
    """(batch (P, longest span, len(columns)), per-particle table: particle, first_frame,
    last_frame, n_observed)."""
    if not isinstance(tracks, pd.DataFrame):
        raise TypeError(f"tracks must be a pandas DataFrame, got {type(tracks).__name__}")
    columns = [str(c) for c in columns]
    missing = [c for c in ["frame", "particle", *columns] if c not in tracks.columns]
    if missing:
        raise ValueError(f"tracks lack the columns {missing}")
    if tracks.empty:
        raise ValueError("tracks is empty: no particle to identify")
    frame = tracks["frame"].to_numpy()
    if not np.issubdtype(frame.dtype, np.number) or not np.all(np.mod(frame, 1) == 0):
        raise ValueError("the frame column must hold integers")
    if frame.dtype.kind in "uf" and not np.all(np.abs(frame) < 2**63):
        raise ValueError("the frame numbers must lie within ±2**63 (int64)")
    data = tracks[["particle", "frame", *columns]].copy()
    data["frame"] = data["frame"].astype(np.int64)
    if data.duplicated(["particle", "frame"]).any():
        raise ValueError("a particle has two rows for one frame")
    data = data.sort_values(["particle", "frame"], kind="stable")
    particle_codes, particles = pd.factorize(data["particle"], sort=True)
    first = data.groupby(particle_codes)["frame"].transform("min").to_numpy()
    offset = data["frame"].to_numpy() - first
    span = int(offset.max()) + 1
    z = np.full((len(particles), span, len(columns)), np.nan)
    values = np.column_stack([real_array(data[c].to_numpy(), f"tracks[{c!r}]") for c in columns])
    z[particle_codes, offset] = values
    info = data.groupby(particle_codes).agg(
        first_frame=("frame", "min"), last_frame=("frame", "max"), n_observed=("frame", "size")
    )
    info.insert(0, "particle", np.asarray(particles))
    return z, info.reset_index(drop=True)
