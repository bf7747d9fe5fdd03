"""Twins of the field kernels."""
