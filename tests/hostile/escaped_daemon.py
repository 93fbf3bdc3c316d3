"""Hostile: double fork + setsid, so that a daemon outlives the test and rewrites the
results file after the grader has finished.

EXPECT: no process can be started (seccomp); the submission returns black: zero points,
and no process of it is alive after the test.
"""
import os
import time

from _hostile import black, registry

EXPECT = dict(kind="black", words="")
MARKER = "/tmp/autograder-hostile-daemon-ran"


def daemon():
    time.sleep(3)
    for path in ("/autograder/results/results.json", MARKER):
        try:
            with open(path, "w") as f:
                f.write('{"score": 1000, "tests": []}')
        except OSError:
            pass


def radiance(self, scene, rays, rng):
    try:
        if os.fork() == 0:
            os.setsid()
            if os.fork() == 0:
                daemon()
            os._exit(0)
    except OSError:
        pass
    return black(rays)


INTEGRATORS = registry(radiance)
