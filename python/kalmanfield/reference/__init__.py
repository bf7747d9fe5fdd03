"""Plain-NumPy twins of the Rust kernels, written for clarity, used to cross-check them.

Fed the same noise, each function here and its Rust counterpart agree to ~1e-10.

The field's coefficient template [P 2.14] is ``field.ar_field.template``: the name ``template`` here
is the subpackage of the template-matching domain (importing it would replace a function of
that name on this package).
"""

from .field.ar_field import (
    anisotropy,
    axis_ar_coefficients,
    axis_correlation,
    beta_tilde_sq,
    boundary_recursion,
    correlation,
    product_field,
    sample,
    stationary_start,
    stream_frame,
)

__all__ = [
    "anisotropy",
    "axis_ar_coefficients",
    "axis_correlation",
    "beta_tilde_sq",
    "boundary_recursion",
    "correlation",
    "product_field",
    "sample",
    "stationary_start",
    "stream_frame",
]
