"""The demo report: one run from a simulated scene to identified objects, written as a
self-contained HTML page with its figures, an animated GIF, the tracks and the numbers
(``kalmanfield demo``; :doc:`/guide/cli`)."""

from .pipeline import DemoSettings, run_demo

__all__ = ["DemoSettings", "run_demo"]
