"""Hostile: kills the grader (its parent), every process it may signal, its process group.

EXPECT: every signal to another process is refused (seccomp; another user under Gradescope);
the grader lives on and the submission gets zero points.
"""
import os
import signal

from _hostile import black, registry

EXPECT = dict(kind="black", words="")


def radiance(self, scene, rays, rng):
    for target in (os.getppid(), -1, 1):
        try:
            os.kill(target, signal.SIGKILL)
        except OSError:
            pass
    try:
        os.killpg(os.getpgid(os.getppid()), signal.SIGKILL)
    except OSError:
        pass
    return black(rays)


INTEGRATORS = registry(radiance)
