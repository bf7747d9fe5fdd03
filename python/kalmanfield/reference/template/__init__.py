"""Plain-NumPy twins of the template domain (``rust/src/template``): the correlation search
(:mod:`.matching`) and the search-recurrent tracker (:mod:`.tracker`)."""

from .matching import match_template, refine_peak, shift, surface
from .tracker import TwinTracker, distinctness, motion_model

__all__ = [
    "TwinTracker",
    "distinctness",
    "match_template",
    "motion_model",
    "refine_peak",
    "shift",
    "surface",
]
