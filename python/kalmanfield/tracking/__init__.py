"""Detection and tracking of moving objects: segmentation of frames into spots and the
branching segment-sequence tracker, with trackpy-style linking (method page *Tracking*)."""

from .branching_tracker import BranchingTracker
from .config import TrackerConfig
from .link import link
from .segment import segment

__all__ = ["BranchingTracker", "TrackerConfig", "link", "segment"]
