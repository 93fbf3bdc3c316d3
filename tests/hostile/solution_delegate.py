"""Hostile: its own class, whose radiance calls the reference integrator's radiance.

EXPECT: in the student runtime the reference radiance is the skeleton's stub: "not
implemented", zero points.
"""
import importlib

from pathtracer.integrators.base import Integrator

module = importlib.import_module("pathtracer.integrators." + "path")


class Delegate(Integrator):
    name = "path"

    def radiance(self, scene, rays, rng):
        return module.PathIntegrator.radiance(self, scene, rays, rng)


INTEGRATORS = {"path": Delegate}
EXPECT = dict(kind="not-implemented", words="not implemented")
