"""Shapes: one module per shape kind, holding its intersection, the surface data of its hits
and the factory that reads it from the scene file (registered with ``@register("shape",
...)``, given the element's ``Props`` with a :class:`~.accumulator.ShapeParams` at
``props.shape``); the ray-scene intersection over
every kind (:mod:`.intersect`), surface derivatives (:mod:`.tangents`) and instancing
(:mod:`.instances`).

Importing the package registers every shape kind (:mod:`pathtracer.scene.registry`).
"""
from . import cube, curves, cylinder, disk, instances, mesh, rectangle, sdfgrid, sphere  # noqa: F401
