"""Moving objects made of fragments: stage 2 of the branching-sequence detector, the
end-to-end detector and the scene simulator (method page *Extended objects*)."""

from .detected import DetectedObject
from .detector import MovingObjectDetector, detect_moving_objects
from .options import DetectorOptions
from .simulate import Scene, Target, simulate_scene

__all__ = [
    "DetectedObject",
    "DetectorOptions",
    "MovingObjectDetector",
    "Scene",
    "Target",
    "detect_moving_objects",
    "simulate_scene",
]
