"""Hostile: reaches the reference integrators through importlib with a computed name, which
no reading of the source can see, and subclasses them without overriding radiance.

EXPECT: the student runtime has no reference solution, only the skeleton's stubs: the class
is refused (its radiance is not written in the submission), zero points.
"""
import importlib

name = "".join(["pathtracer.", "integr", "ators"])
INTEGRATORS = dict(importlib.import_module(name).INTEGRATORS)

EXPECT = dict(kind="output", words="not written in your submission")
