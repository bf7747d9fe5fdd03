"""Identification on a tracker's output: one decision row per particle, equal to running
each particle's trajectory alone (skipped frames as missed ones)."""

import numpy as np
import pandas as pd
import pytest
from filterbank_cases import four_types

import kalmanfield as kf

bank = pytest.fixture(four_types, name="bank")


def test_one_row_per_particle_as_run_alone(bank):
    rows, expected = [], {}
    for particle, truth in enumerate([0, 3, 1, 2, 3]):
        z = bank[truth].simulate(40, seed=particle)[1]
        frames = np.arange(40) + 5 * particle
        keep = np.ones(40, bool)
        keep[[7, 8, 20]] = False  # the tracker lost the particle on these frames
        z_alone = np.where(keep[:, None], z, np.nan)
        ident = kf.TypeIdentifier(bank)
        ident.run(z_alone)
        expected[100 + particle] = (ident.decision, ident.posterior)
        rows.append(
            pd.DataFrame(
                {
                    "frame": frames[keep],
                    "particle": 100 + particle,
                    "x": z[keep, 0],
                    "y": z[keep, 1],
                }
            )
        )
    tracks = pd.concat(rows).sample(frac=1.0, random_state=0)  # any row order
    table = kf.TypeIdentifier.run_tracks(tracks, bank)
    assert list(table["particle"]) == sorted(expected)
    assert (table["n_observed"] == 37).all()
    assert list(table["first_frame"]) == [0, 5, 10, 15, 20]
    for _, row in table.iterrows():
        decision, posterior = expected[row["particle"]]
        assert row["decision"] == decision and row["type"] == bank[decision].name
        got = row[[f"posterior_{m.name}" for m in bank]].to_numpy(dtype=float)
        np.testing.assert_allclose(got, posterior, rtol=1e-12, atol=1e-300)
