"""Fragments that vanish at one edge of an object (method page *Extended objects*, §3.4): the
centroid of a segment whose box extent changed by Δ carries the extra variance (Δ/2)², so a
stripe going dark neither moves the object's velocity nor breaks its sequence; the group's box
keeps the object's extent while a fragment is missing (at most N frames), so a reappearing
fragment joins the group instead of starting a new object."""

from __future__ import annotations

import numpy as np
from test_stage2 import CONFIG as STAGE2

from kalmanfield import _core
from kalmanfield.reference.extended import GroupTracker as TwinTracker

CONFIG = dict(STAGE2, gate_margin=2.0)

V = (3.0, 0.0)


def stripe(x0: float, x1: float, y: float = 30.0) -> list[float]:
    """A segment covering columns x0..x1 and rows y-4..y+4 (area = its pixel count)."""
    area = (x1 - x0 + 1) * 9
    return [0.5 * (x0 + x1), y, 10.0, area, x0, y - 4, x1, y + 4]


def striped_object(t: int, dark: set[int]) -> list[list[float]]:
    """Three 4-px stripes of a 12-px object moving at V; the dark ones are missing; adjacent
    lit stripes form one segment (as after smoothing)."""
    left = 10.0 + V[0] * t
    lit = [k for k in range(3) if k not in dark]
    rows, run = [], [lit[0]]
    for k in lit[1:] + [None]:
        if k is not None and k == run[-1] + 1:
            run.append(k)
            continue
        rows.append(stripe(left + 4 * run[0], left + 4 * run[-1] + 3))
        if k is not None:
            run = [k]
    return rows


def test_dark_stripe_keeps_the_sequence():
    # a 2-px centroid jump with position std 0.3 px is far outside the χ² gate; the box
    # shrank by one stripe (Δ = 4 px), so the centroid's variance grows by (Δ/2)² = 4 and the
    # sequence continues instead of being dropped and restarted
    tracker = _core.GroupTracker(**CONFIG)
    for t in range(8):
        z = np.array(striped_object(t, {2} if t in (4, 5) else set()), dtype=float)
        a = tracker.step(np.ascontiguousarray(z))
        assert a["segment_sequence"].tolist() == [0], t
        assert a["groups"][:, 0].tolist() == [0]
    # the group's velocity stays within the merge tolerance of the true 3 px per frame
    assert abs(a["groups"][0, 3] - V[0]) <= CONFIG["velocity_tolerance"]


def frames_with_dark_stripes() -> list[np.ndarray]:
    dark = {4: {2}, 5: {2}, 9: {0}, 12: {1}, 13: {2}}
    return [np.array(striped_object(t, dark.get(t, set())), dtype=float) for t in range(16)]


def test_dark_stripes_rust_equals_twin():
    rust, twin = _core.GroupTracker(**CONFIG), TwinTracker(CONFIG)
    for z in frames_with_dark_stripes():
        a = rust.step(np.ascontiguousarray(z))
        group, sequence, _, groups, _ = twin.step(z)
        np.testing.assert_allclose(a["groups"], groups, rtol=1e-10, atol=1e-10)
        np.testing.assert_array_equal(a["segment_group"], group)
        np.testing.assert_array_equal(a["segment_sequence"], sequence)
    assert len(groups) == 1  # one object all along


def test_box_held_while_a_fragment_is_missing():
    # the right stripe is dark in frames 4-6 and back at 7 as a separate segment (the middle
    # one is dark then); the group's box kept the object's extent, so the stripe joins the
    # group instead of starting a new one (without the hold the box would end 3 px short)
    config = dict(CONFIG, gate_margin=1.0)
    dark = {4: {2}, 5: {2}, 6: {2}, 7: {1}}
    tracker = _core.GroupTracker(**config)
    for t in range(9):
        z = np.array(striped_object(t, dark.get(t, set())), dtype=float)
        a = tracker.step(np.ascontiguousarray(z))
        assert a["segment_group"].tolist() == [0] * len(z), t
