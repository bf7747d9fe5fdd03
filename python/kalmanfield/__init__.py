"""kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
sequences, with a Rust core.

Formulas and their sources are in SPEC.md; each public item's docstring cites its section.
"""

from .ar_field_model import ARFieldModel
from .field_stream import FieldStream
from .product_field import sample_product_field

__all__ = ["ARFieldModel", "FieldStream", "sample_product_field"]
__version__ = "0.1.0"
