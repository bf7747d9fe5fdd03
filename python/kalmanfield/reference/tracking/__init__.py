"""Twins of the segmentation and of the branching tracker."""
