"""Twin of the stage-2 grouping of extended objects and of the detector's frame kernels
(method page *Extended objects*)."""

from .frames import background_level, box_smooth
from .grouping import GroupTracker, assign

__all__ = ["GroupTracker", "assign", "background_level", "box_smooth"]
