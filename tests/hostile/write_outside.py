"""Hostile: writes outside its folder: the results file, the submission, a sitecustomize.py
in the temporary folder, the working directory.

EXPECT: every write fails (seccomp refuses opening for writing); the submission reports any
that succeeded by raising, so a zero score with no "WROTE" in the message is the pass.
"""
import os
import sys

from _hostile import black, registry

EXPECT = dict(kind="black", words="")


def radiance(self, scene, rays, rng):
    targets = ["/autograder/results/results.json", "/tmp/sitecustomize.py",
               os.path.join(os.getcwd(), "planted.py"), os.path.abspath(__file__) + ".bak",
               os.path.join(sys.path[0], "pathtracer", "planted.py")]
    for path in targets:
        try:
            with open(path, "w") as f:
                f.write("x = 1\n")
        except OSError:
            continue
        raise RuntimeError(f"WROTE {path}")
    try:
        os.unlink(os.path.abspath(__file__))
        raise RuntimeError(f"WROTE (deleted) {__file__}")
    except OSError:
        pass
    return black(rays)


INTEGRATORS = registry(radiance)
