"""Search-recurrent fragment tracking (source [F]): correlation search of a template
(:func:`match_template`) steered by a Kalman predictor (:class:`TemplateTracker`). See the
method page *Template tracker*, §5."""

from .matching import match_template
from .tracker import TemplateTracker, TemplateUpdate

__all__ = ["TemplateTracker", "TemplateUpdate", "match_template"]
