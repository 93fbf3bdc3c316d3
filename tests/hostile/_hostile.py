"""Shared plumbing of the hostile zoo: a registry of integrators whose radiance is an attack.

Each hostile submission is written as a student who has read the grader's source would
write it: it uses only what a submission may import (the tracer's building blocks, NumPy,
the standard library) and returns a black image when its attack fails, so a submission
that gets any point has cheated.

Each attack's ``EXPECT`` says how its test must end: ``kind="black"`` the attack ran to its
end and returned black (no failure: an attack that crashed or raised would prove nothing),
another kind that failure with ``words`` in its message, ``None`` any zero. An attack that
works raises :class:`Escaped`, whose message says ESCAPED, LEAK or WROTE; the tests look for
those words.
"""
import numpy as np

from pathtracer.integrators.base import Integrator

NAMES = ("path", "path_bsdf", "path_nee", "direct")


def black(rays):
    return np.zeros((len(rays), 3))


def registry(radiance) -> dict:
    """Every graded integrator name -> a class whose radiance is ``radiance``."""
    return {name: type(f"Hostile_{name}", (Integrator,), {"name": name, "radiance": radiance})
            for name in NAMES}


class Escaped(RuntimeError):
    """An attack that worked: its message (ESCAPED, LEAK or WROTE ...) fails the zoo's test."""


def libc():
    """The C library through ctypes, as a submission reaches it (no audit hook sees it)."""
    import ctypes
    library = ctypes.CDLL(None, use_errno=True)
    library.syscall.restype = ctypes.c_long
    return library


def errno_of(result) -> int:
    """``errno`` after a failed libc call (0 when ``result`` says it succeeded)."""
    import ctypes
    return ctypes.get_errno() if result == -1 else 0


def grader_pids() -> list:
    """The grader (our parent) and its parent: the processes an attack aims at."""
    import os
    pids = [os.getppid()]
    try:
        with open(f"/proc/{pids[0]}/status") as f:
            pids += [int(line.split()[1]) for line in f if line.startswith("PPid:")]
    except OSError:
        pass
    return [pid for pid in pids if pid > 1]


def grader_argv() -> list:
    """The grader's command line, if /proc lets us read it (it names the results file)."""
    import os
    try:
        with open(f"/proc/{os.getppid()}/cmdline", "rb") as f:
            return [a.decode("utf-8", "replace") for a in f.read().split(b"\0") if a]
    except OSError:
        return []
