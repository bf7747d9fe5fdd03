"""Fields and streams larger than memory, chunk by chunk, equal to the in-memory sample."""

from __future__ import annotations

import pickle
from typing import Any

import numpy as np
import numpy.typing as npt

from .._validation import SeedLike, float_dtype, grid_shape, resolve_seed
from ..field import ARFieldModel, FieldStream
from ..io._optional import optional
from ._dask import dask_array


def sample(
    model: ARFieldModel,
    shape: Any,
    *,
    chunks: Any = "auto",
    seed: SeedLike = None,
    dtype: npt.DTypeLike = np.float64,
    threads: int | None = None,
) -> Any:
    """A realisation of a field model as a dask array, equal to ``model.sample(shape, seed)``.

    Parameters
    ----------
    model : ARFieldModel
        The model; axis 0 is the axis the work is chained along (time, or rows).
    shape : tuple of int
        Grid shape, one length per axis of the model.
    chunks : dask chunks, default "auto"
        Chunks of the result (any chunking dask accepts). The values do not depend on it.
    seed : int, numpy.random.Generator or None, default None
        The seed of :meth:`~kalmanfield.ARFieldModel.sample`; None draws one now (so the
        array's chunks still agree with one another).
    dtype : {numpy.float64, numpy.float32}, default numpy.float64
        The dtype of the field.
    threads : int, optional
        Threads per task (None: all cores of the worker).

    Returns
    -------
    dask.array.Array
        The field, lazily; every element equal bit for bit to ``model.sample(shape,
        seed=seed, dtype=dtype)``, whatever `chunks` and the number of workers.

    Raises
    ------
    TypeError
        `model` is not an ARFieldModel.
    ValueError
        A shape that does not match the model, or what
        :class:`~kalmanfield.FieldStream` refuses.
    ImportError
        dask is not installed (the ``dask`` extra).

    Notes
    -----
    An AR field is a recursion along every axis from an exactly stationary start: every
    slab along axis 0 depends on all the slabs before it, through the last n_0 of them.
    The array is therefore built as a chain of tasks along axis 0, each continuing a
    :class:`~kalmanfield.FieldStream` (which draws slice t from the same random stream as
    ``model.sample``) from the state the previous task handed on (n_0 slabs, pickled), and
    chunks across the other axes are cut from whole slabs. The chain makes the result exact
    and independent of the chunking, at a price: slabs along axis 0 are made one after the
    other (each on all the cores of its worker), while everything downstream of them
    (filtering, writing to zarr) runs in parallel. Independent chunks that are still exact
    are impossible: splitting the recursion would need the state at every chunk border,
    which is the slab before it. A 1-axis model is made in one task. See
    :doc:`/guide/scale_out`.

    Examples
    --------
    >>> import numpy as np
    >>> import kalmanfield as kf
    >>> import kalmanfield.dask as kfd
    >>> model = kf.ARFieldModel([0.9, 0.8], [2, 1])
    >>> lazy = kfd.sample(model, (100, 64), chunks=(30, 32), seed=4)
    >>> bool(np.array_equal(lazy.compute(), model.sample((100, 64), seed=4)))
    True
    """
    da = dask_array()
    delayed = optional("dask", "kalmanfield.dask.sample").delayed
    if not isinstance(model, ARFieldModel):
        raise TypeError(f"model must be an ARFieldModel, got {type(model).__name__}")
    dims = grid_shape(shape, model.ndim)
    dt = float_dtype(dtype, model.sigma)
    seed_value = resolve_seed(seed)
    wanted = da.core.normalize_chunks(chunks, dims, dtype=dt)
    if model.ndim == 1:
        whole = delayed(model.sample)(dims, seed=seed_value, dtype=dt, threads=threads)
        return da.from_delayed(whole, dims, dtype=dt).rechunk(wanted)
    stream = FieldStream(model, dims[1:], seed=seed_value, dtype=dt, threads=threads)
    state = pickle.dumps(stream)
    slabs = []
    for count in wanted[0]:
        step = delayed(_continue, nout=2, pure=True)(state, count)
        slabs.append(da.from_delayed(step[0], (count, *dims[1:]), dtype=dt))
        state = step[1]
    return da.concatenate(slabs, axis=0).rechunk(wanted)


def _continue(state: bytes, count: int) -> tuple[np.ndarray, bytes]:
    """The next `count` slabs of a pickled stream, and its state after them."""
    stream = pickle.loads(state)
    slab = stream.take(count)
    return slab, pickle.dumps(stream)
