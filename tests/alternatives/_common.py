"""Shared plumbing of the correct alternatives (tests/alternatives/).

Every module here is an implementation in the student's contract (``INTEGRATORS``,
``camera_rays``), correct but written differently from the reference solution: another
heuristic, roulette rule, order of random numbers or light choice. Each must get full marks
on every check (tests/test_autograder.py): the grader must not punish a right answer for
not being Mitsuba's. A module's docstring says what differs and why it is still unbiased.
"""
from pathtracer.camera import camera_rays  # noqa: F401  (re-exported: the reference camera)
from pathtracer.integrators import INTEGRATORS as REFERENCE


def registry(*classes) -> dict:
    """The reference INTEGRATORS with the given classes replacing those of the same name."""
    out = dict(REFERENCE)
    for cls in classes:
        out[cls.name] = cls
    return out
