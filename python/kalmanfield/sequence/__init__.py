"""Filtering frame sequences in space and time (method page :doc:`/methods/sequence_filter`):
:class:`SequenceFilter`, the exact Kalman filter over frames per spatial eigenmode (with
fixed-lag smoothing) and its fast O(H·W)-per-frame counterpart."""

from .sequence_filter import SequenceFilter

__all__ = ["SequenceFilter"]
