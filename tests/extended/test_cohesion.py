"""The group merge by cohesion (method page *Extended objects*, §3.4, "Split and merge"):
co-moving fragments farther apart than the gate margin but within their own size of each
other become one object; `cohesion=0` keeps the margin alone. Rust and its twin agree."""

from __future__ import annotations

import numpy as np
import pytest
from test_stage2 import CONFIG, blob, run_both

# two 5 × 5 fragments whose boxes are 5 px apart: beyond gate_margin (4), within their extent (5)
PAIR = np.array([[-4.5, 0.0], [4.5, 0.0]])


def pair_frames(v=(1.5, 0.5), n=8):
    return [
        [blob(10.0 + v[0] * t + dx, 20.0 + v[1] * t + dy, half=2.0) for dx, dy in PAIR]
        for t in range(n)
    ]


def groups_of_fragments(config):
    out = []
    for a, (group, *_rest) in run_both(pair_frames(), config):
        np.testing.assert_array_equal(a["segment_group"], group)
        out.append(len(set(a["segment_group"].tolist())))
    return out


def test_cohesion_merges_co_moving_fragments_beyond_the_margin():
    counts = groups_of_fragments(dict(CONFIG, cohesion=1.0))
    # born as two groups; both mature (a sequence longer than ν + 1 = 2) in frame 2: one object
    assert counts[:2] == [2, 2] and set(counts[2:]) == {1}


def test_cohesion_zero_keeps_the_margin_alone():
    assert set(groups_of_fragments(dict(CONFIG, cohesion=0.0))) == {2}


def test_fragments_moving_apart_do_not_merge():
    frames = [
        [blob(10.0 + 1.5 * t - 4.5, 20.0, half=2.0), blob(10.0 - 1.5 * t + 4.5, 20.0, half=2.0)]
        for t in range(8)
    ]
    for a, _ in run_both(frames):
        assert len(set(a["segment_group"].tolist())) == 2


@pytest.mark.parametrize("cohesion", [-1.0, float("nan")])
def test_bad_cohesion(cohesion):
    from kalmanfield import _core

    with pytest.raises(ValueError, match="cohesion"):
        _core.GroupTracker(**dict(CONFIG, cohesion=cohesion))
