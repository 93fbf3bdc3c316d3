"""Shapes: the ray-scene intersection over every shape kind, each analytic shape's
intersection and surface data, surface derivatives, and instancing."""
