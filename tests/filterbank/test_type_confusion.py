"""The type-confusion experiment [I, fig. 3] on a CI-sized run: it starts at chance, falls
as frames accumulate, its intervals hold the estimates, the same seed gives the same table,
and it plots."""

import numpy as np
import pytest

from kalmanfield.experiments import ACCELERATION, VELOCITY, source_banks, type_confusion


def test_confusion_falls_from_chance():
    result = type_confusion(n_frames=60, runs=300, progress=False)
    table = result.table
    assert list(table.columns) == ["bank", "frame", "confusion", "low", "high", "trials"]
    assert set(table["bank"]) == {VELOCITY, ACCELERATION}
    assert ((table["low"] <= table["confusion"]) & (table["confusion"] <= table["high"])).all()
    for bank in (VELOCITY, ACCELERATION):
        confusion = result.confusion(bank)
        # frame 1: chance (600 trials, SE 0.02); frame 60: well below (measured ≤ 0.15)
        assert abs(confusion.iloc[0] - 0.5) < 0.08
        assert confusion.iloc[-10:].mean() < 0.25
        assert confusion.iloc[-10:].mean() < confusion.iloc[:10].mean() / 2
    again = type_confusion(n_frames=60, runs=300, progress=False)
    assert again.table.equals(table)


def test_custom_banks_and_plot():
    banks = {"pair": source_banks((0.95, 0.2), 0.5, 1.0)[VELOCITY]}
    result = type_confusion(banks, n_frames=10, runs=50, seed=3, progress=False)
    assert len(result.table) == 10 and (result.table["trials"] == 100).all()
    assert np.isnan(result.ratio("pair", "pair")).sum() <= 10
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    ax = result.plot()
    assert ax.get_xlabel() == "frame"
