"""Plain-NumPy twins of the template domain (``rust/src/template``): the correlation search
(:mod:`.matching`) and the search-recurrent tracker (:mod:`.tracker`)."""

from .matching import match_template, refine_peak, shift, surface

__all__ = ["match_template", "refine_peak", "shift", "surface"]
