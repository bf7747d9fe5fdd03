"""link's table checks (issue 49, items 10–12): frame numbers, column types, the progress bar."""

import numpy as np
import pandas as pd
import pytest

import kalmanfield as kf

LINK_KW = dict(measurement_std=0.5, process_std=0.1)


def _track(frames=8):
    """Two straight tracks and the frame column as given."""
    f = np.repeat(np.arange(frames), 2)
    x = np.where(np.arange(2 * frames) % 2, 50.0, 10.0) + 1.0 * f
    return pd.DataFrame({"frame": f, "x": x, "y": 20.0 + 0.5 * f})


@pytest.mark.parametrize("top", [2**63, 2**64 - 1])
def test_uint64_frame_numbers_beyond_int64_are_refused(top):
    """(they wrapped round to negative int64: a detection at frame 2**64 − 1 joined track 0 as
    frame −1)"""
    det = _track()
    det["frame"] = det["frame"].astype(np.uint64)
    det.loc[len(det) - 1, "frame"] = np.uint64(top)
    with pytest.raises(ValueError, match="within int64"):
        kf.link(det, **LINK_KW)
    det["frame"] = pd.array(det["frame"], dtype="UInt64")
    with pytest.raises(ValueError, match="within int64"):
        kf.link(det, **LINK_KW)


def test_uint64_frame_numbers_within_int64_link_as_int64_ones():
    det = _track()
    want = kf.link(det, **LINK_KW)
    assert (want.particle >= 0).all()
    got = kf.link(det.assign(frame=det.frame.astype(np.uint64)), **LINK_KW)
    np.testing.assert_array_equal(got.particle, want.particle)


@pytest.mark.parametrize(
    "column",
    [
        lambda x: x.astype(complex),
        lambda x: x.astype(complex) + 1j,
        lambda x: x.astype(str),
        lambda x: x.astype(str).astype(object),
        lambda x: x > 20,
        lambda x: x.astype(object).where(x < 15, "12"),
    ],
)
def test_complex_bool_and_string_columns_are_refused(column):
    """(complex columns were cut to their real part with a ComplexWarning, numeric strings
    parsed)"""
    det = _track()
    for name in ("x", "y"):
        with pytest.raises(TypeError, match=f"column '{name}' must hold real numbers"):
            kf.link(det.assign(**{name: column(det[name])}), **LINK_KW)
    with pytest.raises(TypeError, match="column 'area' must hold real numbers"):
        kf.link(det.assign(area=column(det["x"])), features=["area"], **LINK_KW)


def test_nullable_and_integer_columns_are_numbers():
    det = _track()
    want = kf.link(det, **LINK_KW).particle
    ints = det.assign(x=det.x.round().astype(int), y=det.y.round().astype(int))
    nullable = ints.assign(x=pd.array(ints.x, dtype="Int64"), y=pd.array(ints.y, dtype="Float64"))
    np.testing.assert_array_equal(
        kf.link(nullable, **LINK_KW).particle, kf.link(ints, **LINK_KW).particle
    )
    assert (want >= 0).all()
    nullable.loc[3, "y"] = pd.NA
    with pytest.raises(ValueError, match="must be finite"):
        kf.link(nullable, **LINK_KW)


def test_progress_bar_works_and_changes_nothing(capsys):
    """(tqdm was only in the bench extra: ModuleNotFoundError)"""
    det = _track()
    quiet = kf.link(det, **LINK_KW)
    shown = kf.link(det, progress=True, **LINK_KW)
    pd.testing.assert_frame_equal(shown, quiet)
    assert "link" in capsys.readouterr().err
