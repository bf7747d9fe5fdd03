"""The product model (method page *Random fields*, §1.4; [P 2.18])."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from .._validation import (
    SeedLike,
    ShapeLike,
    allocate,
    check_given_noise_output,
    finite_noise,
    float_dtype,
    grid_shape,
    resolve_seed,
    thread_count,
)
from .model import ARFieldModel


def sample_product_field(
    model: ARFieldModel,
    shape: ShapeLike,
    seed: SeedLike = None,
    noise: Sequence[npt.ArrayLike] | None = None,
    dtype: npt.DTypeLike = np.float64,
    threads: int | None = None,
) -> np.ndarray:
    """A product field x_ī = σ Π_k s⁽ᵏ⁾_{i_k} of independent 1-D sequences, one per axis.

    Each s⁽ᵏ⁾ is a unit-variance stationary sequence of axis k's model, so the field has the
    correlation function σ² Π_k R_k of :meth:`ARFieldModel.sample` but is not Gaussian.

    Parameters
    ----------
    model : ARFieldModel
        The model whose axis models make the sequences.
    shape : int or tuple of int
        Grid shape, one length per axis.
    seed : int, numpy.random.Generator or None, default None
        Seed (None: OS entropy).
    noise : sequence of array_like, optional
        One standard-normal 1-D array per axis, of length ``shape[k]``, driving the
        sequences; `seed` is then ignored.
    dtype : {numpy.float64, numpy.float32}, default numpy.float64
        Output dtype.
    threads : int, optional
        Number of threads (None: all cores).

    Returns
    -------
    numpy.ndarray
        The field, of `shape` and `dtype`.

    Raises
    ------
    TypeError
        `model` is not an ARFieldModel, `noise` is not a sequence of arrays.
    ValueError
        A shape that does not match the model; noise of the wrong count, length or not
        finite, or whose field leaves the dtype's range.

    Notes
    -----
    O(1) work per element. For two axes the marginal density is ``K₀(|x|/σ²)/(πσ²)`` (§1.4 of
    :doc:`/methods/random_fields`, with the source's missing 1/π restored).

    References
    ----------
    .. [1] O. V. Popov, dissertation, Ulyanovsk, 2000, eq. 2.18 ([P] in :doc:`/references`).

    Examples
    --------
    >>> import kalmanfield as kf
    >>> model = kf.ARFieldModel([0.9, 0.9], [2, 2])
    >>> kf.sample_product_field(model, (128, 128), seed=3).shape
    (128, 128)
    """
    if not isinstance(model, ARFieldModel):
        raise TypeError(f"model must be an ARFieldModel, got {type(model).__name__}")
    dims = grid_shape(shape, model.ndim)
    dt = float_dtype(dtype, model.sigma)
    given = None
    if noise is not None:
        if isinstance(noise, (str, bytes)) or not isinstance(noise, (Sequence, np.ndarray)):
            raise TypeError(
                f"noise must be a sequence of {model.ndim} 1-D arrays (one per axis), "
                f"got {type(noise).__name__}"
            )
        if len(noise) != model.ndim:
            raise ValueError(f"noise must hold {model.ndim} 1-D arrays, got {len(noise)}")
        given = [finite_noise(s, (n,), f"noise[{k}]") for k, (s, n) in enumerate(zip(noise, dims))]
    out = allocate(dims, dt)
    threads = thread_count(threads)
    model._core.product_into(out, 0 if given else resolve_seed(seed), given, threads)
    if given is not None:
        check_given_noise_output(out)
    return out
