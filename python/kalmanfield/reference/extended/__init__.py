"""Twin of the stage-2 grouping of extended objects (method page *Extended objects*)."""

from .grouping import GroupTracker, assign

__all__ = ["GroupTracker", "assign"]
