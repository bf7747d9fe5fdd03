"""Reproductions of the sources' experiments (Monte Carlo studies with plots)."""

from .type_confusion import ACCELERATION, VELOCITY, TypeConfusion, source_banks, type_confusion

__all__ = ["ACCELERATION", "VELOCITY", "TypeConfusion", "source_banks", "type_confusion"]
