"""Identification of field models from data: the AR fit with its whiteness test, the
sample correlation, Yule–Walker models, and the fit from a noisy image (method page
*Identification*)."""

from .fit import AxisFit, IdentifiedModel, WhitenessTest, identify
from .from_noisy import model_from_noisy
from .sample_correlation import sample_correlation
from .yule_walker import YuleWalkerModel, yule_walker

__all__ = [
    "AxisFit",
    "IdentifiedModel",
    "WhitenessTest",
    "YuleWalkerModel",
    "identify",
    "model_from_noisy",
    "sample_correlation",
    "yule_walker",
]
