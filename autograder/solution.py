"""The reference solution in the student's contract (see :mod:`autograder.contract`).

The project's integrators and camera, unchanged: grading this module must give full marks,
and :mod:`autograder.skeleton` derives the student skeleton from the same sources.
"""
from pathtracer.integrators import INTEGRATORS
from pathtracer.sensors.perspective import camera_rays

__all__ = ["INTEGRATORS", "camera_rays"]
