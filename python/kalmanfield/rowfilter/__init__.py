"""Row-by-row Kalman filtering of images: the quasi-optimal scalar filter, the optimal
vector filter, and the Wiener bound they are measured against (method page *Row filters*)."""

from .scalar import ScalarRowFilter
from .vector import VectorRowFilter
from .wiener_bound import wiener_bound, wiener_error_map

__all__ = ["ScalarRowFilter", "VectorRowFilter", "wiener_bound", "wiener_error_map"]
