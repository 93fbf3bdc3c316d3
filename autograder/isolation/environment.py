"""Where and as whom a submission runs, and the check that it can read nothing private.

:class:`Environment` names the interpreter, the folders it imports NumPy and SciPy from, and
the unprivileged user (when the grader runs as root); :func:`kill_user_processes` ends
everything that user runs; :func:`audit_environment` proves, as that user, that the
references, the solution and the grader are out of reach before anything is graded
(:func:`require_safe_environment`). :mod:`autograder.isolation.process` starts the child.
"""
from __future__ import annotations

import ctypes
import json
import os
import pwd
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy
import scipy
import threadpoolctl

import autograder
import pathtracer
from mitsuba_refs.reference import cache_location

from . import runtime as runtimes

#: Unprivileged user the child runs as when the grader runs as root.
ENV_STUDENT_USER = "AUTOGRADER_STUDENT_USER"
#: Interpreter the child runs (default: the grader's), and the folders it imports NumPy and
#: SciPy from (default: where the grader's come from), ``os.pathsep``-separated.
ENV_STUDENT_PYTHON = "AUTOGRADER_STUDENT_PYTHON"
ENV_STUDENT_SITE = "AUTOGRADER_STUDENT_SITE"


@dataclass
class Environment:
    """Where and as whom the child runs.

    Attributes
    ----------
    python : str  the interpreter
    site : list of str  folders with NumPy, SciPy and threadpoolctl
    user : str or None  the unprivileged user (only when the grader runs as root)
    """

    python: str = field(default_factory=lambda: os.environ.get(ENV_STUDENT_PYTHON)
                        or sys.executable)
    site: list = field(default_factory=lambda: _site_dirs())
    user: str | None = field(default_factory=lambda: os.environ.get(ENV_STUDENT_USER) or None)

    def ids(self):
        """(uid, gid) of the user, or None when the child runs as the grader's user."""
        if not self.user or os.geteuid() != 0:
            return None
        entry = pwd.getpwnam(self.user)
        return entry.pw_uid, entry.pw_gid


def _site_dirs() -> list:
    given = os.environ.get(ENV_STUDENT_SITE)
    if given:
        return [p for p in given.split(os.pathsep) if p]
    dirs = [str(Path(m.__file__).resolve().parent.parent) for m in (numpy, scipy)]
    dirs.append(str(Path(threadpoolctl.__file__).resolve().parent))
    return list(dict.fromkeys(dirs))


class SetupError(Exception):
    """The grading environment is not safe or not usable (a message for the course staff)."""


PR_GET_DUMPABLE, PR_SET_DUMPABLE = 3, 4


def protect_grader() -> None:
    """Make the grader's process non-dumpable (``PR_SET_DUMPABLE`` 0) before a child starts.

    The kernel then lets no process without CAP_SYS_PTRACE trace it or open its
    ``/proc/<pid>/mem``, ``environ``, ``maps`` or ``fd`` (the ptrace access check), even one
    of the same user: the references and results in its memory stay its own. Raises
    :class:`SetupError` on Linux if the flag does not stick; elsewhere the sandbox refuses
    to start anyway.
    """
    if not sys.platform.startswith("linux"):
        return
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_DUMPABLE, 0, 0, 0, 0)
    if libc.prctl(PR_GET_DUMPABLE, 0, 0, 0, 0) != 0:
        raise SetupError("cannot make the grader's process non-dumpable (prctl PR_SET_DUMPABLE: "
                         f"{os.strerror(ctypes.get_errno())}); refusing to start a submission")


# ----------------------------------------------------------------------------------------
# Processes and permissions of the student user


def user_processes(uid: int) -> list:
    """Pids of every process owned by ``uid``."""
    pids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                if os.stat(f"/proc/{entry}").st_uid == uid:
                    pids.append(int(entry))
            except OSError:
                pass
    return pids


def kill_user_processes(uid: int, seconds: float = 5.0) -> int:
    """SIGKILL every process of ``uid`` until none is left; returns how many were killed.

    The user must be dedicated to the grader (one grader at a time): anything it runs is a
    submission's.
    """
    if uid == 0 or uid == os.getuid():
        raise ValueError("refusing to kill the grader's own user's processes")
    killed, stop = 0, time.monotonic() + seconds
    while time.monotonic() < stop:
        pids = user_processes(uid)
        if not pids:
            break
        for pid in pids:
            try:
                os.kill(pid, signal.SIGKILL)
                killed += 1
            except OSError:
                pass
        time.sleep(0.01)
    return killed


#: Checked once per grader process and environment.
_AUDITED = {}

PROBE = """
import json, os, sys
readable = []
for root in json.loads(sys.argv[1]):
    for folder, dirs, files in os.walk(root):
        for name in files + dirs:
            path = os.path.join(folder, name)
            if os.access(path, os.R_OK) and not os.path.isdir(path):
                readable.append(path)
        if os.access(folder, os.R_OK) and folder != root:
            readable.append(folder)
    if os.access(root, os.R_OK) and os.path.isfile(root):
        readable.append(root)
import numpy
print(json.dumps(readable))
"""


def private_paths(extra=()) -> list:
    """What a submission must not read: the references, the solution, the grader."""
    tracer = Path(pathtracer.__file__).resolve().parent
    paths = [cache_location.committed_dir(), cache_location.cache_dir(), tracer / "integrators",
             tracer / "sensors" / "perspective.py", Path(autograder.__file__).parent, *extra]
    paths += runtimes.public_solution_runtimes()
    return sorted({str(Path(p).resolve()) for p in paths if Path(p).exists()})


def audit_environment(environment: Environment | None = None, extra=()) -> list:
    """Check, as the student user, that the child can run and can read nothing private.

    Returns the private paths the student user can read (empty when safe). Only meaningful
    when the child runs as its own user; returns ``[]`` otherwise.

    Raises
    ------
    SetupError
        The student user cannot run the interpreter or import NumPy.
    """
    environment = environment or Environment()
    ids = environment.ids()
    if not ids:
        return []
    key = (environment.python, tuple(environment.site), environment.user, tuple(extra))
    if key in _AUDITED:
        return _AUDITED[key]
    code = "import sys; sys.path[:0] = " + repr(environment.site) + "\n" + PROBE
    roots = private_paths(extra)
    try:
        done = subprocess.run([environment.python, "-S", "-E", "-s", "-B", "-c", code,
                               json.dumps(roots)], capture_output=True, text=True, timeout=120,
                              cwd="/", user=ids[0], group=ids[1], extra_groups=[],
                              env={"PATH": "/usr/bin:/bin"})
    except (OSError, subprocess.SubprocessError) as error:
        raise SetupError(f"the student user {environment.user!r} cannot run "
                         f"{environment.python}: {error}") from None
    if done.returncode != 0:
        raise SetupError(f"the student user {environment.user!r} cannot run "
                         f"{environment.python} with NumPy from {environment.site}: "
                         f"{done.stderr.strip()[-500:]}")
    _AUDITED[key] = json.loads(done.stdout)
    return _AUDITED[key]


def require_safe_environment(environment: Environment | None = None, extra=()) -> None:
    """Raise :class:`SetupError` unless :func:`audit_environment` finds nothing readable."""
    readable = audit_environment(environment, extra)
    if readable:
        shown = "\n  ".join(readable[:10]) + ("\n  ..." if len(readable) > 10 else "")
        raise SetupError(f"the student user can read {len(readable)} private file(s) (references, "
                         f"the solution or the grader); make them readable by root only "
                         f"(the Gradescope setup.sh does), e.g.:\n  {shown}")
