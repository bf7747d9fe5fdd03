"""kalmanfield: Markov (autoregressive) random fields and Kalman recursions for image
sequences, with a Rust core.

Formulas and their sources are in SPEC.md; each public item's docstring cites its section.
"""

from .ar_field_model import ARFieldModel
from .branching_tracker import BranchingTracker
from .denoise import denoise, estimate_noise_var, local_moments, model_from_noisy
from .field_stream import FieldStream
from .identification import AxisFit, IdentifiedModel, WhitenessTest, identify
from .link import link
from .product_field import sample_product_field
from .sample_correlation import sample_correlation
from .scalar_row_filter import ScalarRowFilter
from .segmentation import segment
from .template import TemplateTracker, TemplateUpdate, match_template
from .vector_row_filter import VectorRowFilter
from .wiener_bound import wiener_bound, wiener_error_map
from .yule_walker import YuleWalkerModel, yule_walker

__all__ = [
    "ARFieldModel",
    "AxisFit",
    "BranchingTracker",
    "FieldStream",
    "IdentifiedModel",
    "ScalarRowFilter",
    "TemplateTracker",
    "TemplateUpdate",
    "VectorRowFilter",
    "WhitenessTest",
    "YuleWalkerModel",
    "denoise",
    "estimate_noise_var",
    "local_moments",
    "identify",
    "link",
    "match_template",
    "model_from_noisy",
    "sample_correlation",
    "sample_product_field",
    "segment",
    "wiener_bound",
    "wiener_error_map",
    "yule_walker",
]
__version__ = "0.1.0"
