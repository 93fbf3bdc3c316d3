"""Hostile: a fork bomb (and a thread bomb when forks fail).

EXPECT: forks fail at once; threads stop at the process limit or the time limit; the
grader survives and the test ends with zero points.
"""
import os
import threading
import time

from _hostile import black, registry

EXPECT = dict(kind="black", words="")


def radiance(self, scene, rays, rng):
    for _ in range(200):
        try:
            os.fork()
        except OSError:
            break
    for _ in range(200):
        try:
            threading.Thread(target=time.sleep, args=(0.5,), daemon=True).start()
        except (RuntimeError, OSError):
            break
    return black(rays)


INTEGRATORS = registry(radiance)
