"""Reproductions of the sources' experiments (Monte Carlo studies with plots)."""

from .k93 import k93, k93_correct, plot_k93
from .type_confusion import ACCELERATION, VELOCITY, TypeConfusion, source_banks, type_confusion

__all__ = [
    "ACCELERATION",
    "VELOCITY",
    "TypeConfusion",
    "k93",
    "k93_correct",
    "plot_k93",
    "source_banks",
    "type_confusion",
]
