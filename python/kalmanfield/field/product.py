"""The product model of SPEC §1.4 [P 2.18]."""

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
    """x_ī = σ Π_k s^{(k)}_{i_k} from N independent unit-variance stationary 1-D sequences of
    the axis models (SPEC §1.4, [P 2.18]).

    Same correlation function σ² Π R_k as :meth:`ARFieldModel.sample` but not Gaussian (for two
    axes the marginal density is K0(|x|/σ²)/(πσ²)); O(1) work per element.
    `noise`, when given, is one standard-normal 1-D array per axis, of length shape[k]
    (ValueError when the field it makes leaves the dtype's range).
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
