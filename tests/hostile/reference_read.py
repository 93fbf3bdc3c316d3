"""Hostile: looks for the committed Mitsuba references (EXR files) to return them.

It searches where a student who read the grader's source would look: Gradescope's source
folder, every folder above the interpreter and the submission, /tmp. EXPECT: nothing
readable (a sandbox PermissionError or an unreadable folder); the submission then returns
black: zero points, and the test checks it never reported a file it could read.
"""
import glob
import os
import sys

from _hostile import black, registry

EXPECT = dict(kind="black", words="")


def candidates():
    roots = {"/autograder/source", "/tmp"}
    for start in (sys.executable, __file__, os.getcwd()):
        path = os.path.abspath(start)
        for _ in range(6):
            path = os.path.dirname(path)
            roots.add(path)
    found = []
    for root in roots:
        for pattern in ("mitsuba_refs/references/*.exr", "*/mitsuba_refs/references/*.exr",
                        "*/*/mitsuba_refs/references/*.exr"):
            try:
                found += glob.glob(os.path.join(root, pattern))
            except OSError:
                pass
    return found


FOUND = candidates()          # searched once, at import


def radiance(self, scene, rays, rng):
    for path in FOUND:
        try:
            with open(path, "rb") as f:
                f.read(16)
        except OSError:
            continue
        raise RuntimeError(f"LEAK: read {path}")
    return black(rays)


INTEGRATORS = registry(radiance)
