"""The render driver: scheduling over worker processes, per-pixel moments, splatting with
replicas, and per-path-class renders. ``render`` and ``RenderResult`` are the public API."""
from .driver import RenderResult, render

__all__ = ["RenderResult", "render"]
