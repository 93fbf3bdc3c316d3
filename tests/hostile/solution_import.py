"""Hostile: hands in the reference solution itself.

EXPECT: refused before it runs (it imports the reference integrators), zero points.
"""
from pathtracer.integrators import INTEGRATORS  # noqa: F401  (the import is what the grader must refuse)

EXPECT = dict(kind="refused", words="imports the reference solution")
