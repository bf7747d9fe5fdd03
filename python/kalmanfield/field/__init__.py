"""Random fields: separable autoregressions with multiple roots, exactly stationary, sampled
whole or streamed frame by frame (method page *Random fields*)."""

from .model import ARFieldModel
from .product import sample_product_field
from .stream import FieldStream

__all__ = ["ARFieldModel", "FieldStream", "sample_product_field"]
