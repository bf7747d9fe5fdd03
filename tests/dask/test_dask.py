"""kalmanfield.dask against the in-memory computations: the same bits whatever the chunking,
on dask's threads and on a dask.distributed LocalCluster."""

import numpy as np
import pandas as pd
import pytest

import kalmanfield as kf

da = pytest.importorskip("dask.array")
pytest.importorskip("dask.dataframe")
distributed = pytest.importorskip("distributed")
kfd = pytest.importorskip("kalmanfield.dask")

from kalmanfield.experiments import type_confusion  # noqa: E402


@pytest.fixture(scope="module")
def client():
    # two workers of one thread each, in this process (no start-up of processes)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as c,
    ):
        yield c


@pytest.fixture(scope="module")
def noisy():
    x = kf.ARFieldModel([0.9, 0.9, 0.9], [1, 2, 2]).sample((10, 48, 40), seed=2)
    return x + np.random.default_rng(3).normal(0, 0.5, x.shape)


@pytest.mark.parametrize(
    "rho, order, shape, chunks",
    [
        ([0.9, 0.8], [2, 1], (101, 37), (10, 37)),
        ([0.9, 0.8], [2, 1], (101, 37), (33, 8)),
        ([0.95, 0.9, 0.7], [1, 2, 3], (23, 16, 12), (4, 5, 12)),
        ([0.95, 0.9, 0.7], [3, 1, 1], (23, 16, 12), (1, 16, 6)),
        ([0.9], [4], (500,), (64,)),
    ],
)
def test_sample_equals_the_in_memory_sample_whatever_the_chunks(rho, order, shape, chunks):
    model = kf.ARFieldModel(rho, order, 1.5)
    lazy = kfd.sample(model, shape, chunks=chunks, seed=11)
    assert lazy.chunks == da.core.normalize_chunks(chunks, shape)
    assert np.array_equal(lazy.compute(), model.sample(shape, seed=11))


def test_sample_on_a_cluster_and_in_float32(client):
    model = kf.ARFieldModel([0.9, 0.9, 0.9], [1, 2, 2])
    lazy = kfd.sample(model, (17, 20, 24), chunks=(3, 10, 24), seed=5, dtype=np.float32)
    got = client.compute(lazy).result()
    assert got.dtype == np.float32
    assert np.array_equal(got, model.sample((17, 20, 24), seed=5, dtype=np.float32))


def test_sample_refuses_what_sample_refuses():
    model = kf.ARFieldModel([0.9, 0.9], [1, 1])
    with pytest.raises(ValueError):
        kfd.sample(model, (10, 10, 10), chunks=5, seed=1)
    with pytest.raises(TypeError):
        kfd.sample("model", (10, 10), chunks=5, seed=1)


@pytest.mark.parametrize("chunks", [1, 3, 10])
def test_denoise_equals_the_in_memory_denoise(noisy, chunks, client):
    model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    lazy = kfd.denoise(
        da.from_array(noisy, chunks=(chunks, 48, 40)), model=model, noise_var=0.25, mean=0.0
    )
    expected = kf.denoise(noisy, model=model, noise_var=0.25, mean=0.0, method="stationary")
    assert np.array_equal(client.compute(lazy).result(), expected)


def test_denoise_fits_once_and_chunks_agree(noisy):
    one = kfd.denoise(da.from_array(noisy, chunks=(1, 48, 40))).compute()
    all_ = kfd.denoise(da.from_array(noisy, chunks=(10, 48, 40))).compute()
    assert np.array_equal(one, all_)
    model, mean, noise_var = kf.model_from_noisy(noisy[0])
    expected = kf.denoise(noisy, model=model, noise_var=noise_var, mean=mean, method="stationary")
    assert np.array_equal(one, expected)


def test_adaptive_denoise_and_filter(noisy):
    lazy = kfd.denoise(da.from_array(noisy, chunks=(4, 48, 40)), method="adaptive", sigma=0.5)
    assert np.array_equal(lazy.compute(), kf.denoise(noisy, sigma=0.5, method="adaptive"))
    row_filter = kf.ScalarRowFilter(kf.ARFieldModel([0.9, 0.9], [2, 2]), 0.25, 40, smooth=True)
    lazy = kfd.filter(da.from_array(noisy, chunks=(3, 24, 20)), row_filter)
    assert np.array_equal(lazy.compute(), row_filter.filter(noisy))


def test_denoise_refuses_auto_and_bad_settings(noisy):
    with pytest.raises(ValueError, match="auto"):
        kfd.denoise(noisy, method="auto")
    with pytest.raises(ValueError, match="not both"):
        kfd.denoise(noisy, sigma=0.5, noise_var=0.25)
    with pytest.raises(ValueError, match="fit_frame"):
        kfd.denoise(noisy, fit_frame=10)
    with pytest.raises(ValueError, match="stack"):
        kfd.denoise(noisy[0])
    with pytest.raises(TypeError):
        kfd.filter(noisy, "filter")


@pytest.mark.parametrize("threshold", [1.0, "otsu"])
def test_segment_equals_the_in_memory_segment(noisy, threshold, client):
    table = kfd.segment(da.from_array(noisy, chunks=(3, 48, 40)), threshold, min_area=2)
    got = client.compute(table).result().reset_index(drop=True)
    expected = kf.segment(noisy, threshold, min_area=2, frame_no=0)
    pd.testing.assert_frame_equal(got, expected)
    assert got["frame"].nunique() == 10


def test_segment_refuses_a_callable_threshold(noisy):
    with pytest.raises(ValueError, match="callable"):
        kfd.segment(noisy, np.median)
    with pytest.raises(ValueError):
        kfd.segment(noisy, "median")
    with pytest.raises(TypeError):
        kfd.segment(noisy, 1.0, labels=True)


def test_run_experiment_on_a_cluster_equals_the_in_memory_run(client):
    spread = kfd.run_experiment("type-confusion", client, n_frames=15, runs=40, seed=9)
    here = type_confusion(n_frames=15, runs=40, seed=9, progress=False)
    pd.testing.assert_frame_equal(spread.table, here.table)


def test_run_experiment_refuses_an_unknown_name():
    with pytest.raises(ValueError, match="type-confusion"):
        kfd.run_experiment("k95")
