"""No capabilities and no way to regain any, before the submission is imported.

A child started by a grader that runs as root, without a student user of its own, begins as
root with every capability. :func:`drop` leaves it without any: the bounding set emptied,
securebits that give root no capability on exec and lock that, no ambient capabilities,
permitted, effective and inheritable sets empty, and ``PR_SET_NO_NEW_PRIVS`` (no setuid or
file-capability program can give any back, and the seccomp filter may be installed). It then
checks ``/proc/self/status`` and reports what it found; the child refuses to run a
submission unless every set but the bounding one is empty (without CAP_SETPCAP, e.g. as the
student user, the bounding set cannot be emptied and no longer matters: no new privileges).

Root's *real* uid is moved to a uid of its own (``SCRATCH_UID_BASE`` + pid, used by nobody),
so that the kernel counts its threads against ``RLIMIT_NPROC`` (it never does for real uid
0); file access still goes by the effective uid 0 (bounded by Landlock, not by permission
bits).
"""
from __future__ import annotations

import ctypes
import os

PR_CAPBSET_DROP, PR_SET_SECUREBITS, PR_SET_NO_NEW_PRIVS, PR_CAP_AMBIENT = 24, 28, 38, 47
PR_CAP_AMBIENT_CLEAR_ALL = 4
#: SECBIT_NOROOT, SECBIT_NO_SETUID_FIXUP, SECBIT_NO_CAP_AMBIENT_RAISE, each locked, and
#: SECBIT_KEEP_CAPS locked off.
SECUREBITS = 0x01 | 0x02 | 0x04 | 0x08 | 0x20 | 0x40 | 0x80
CAP_SETUID, CAP_SETPCAP = 7, 8
LINUX_CAPABILITY_VERSION_3 = 0x20080522
#: First uid of the range a root child's real uid moves to (systemd leaves
#: 0x70000000-0x7FFDFFFF unassigned; pids stay below 2**22).
SCRATCH_UID_BASE = 0x70000000
#: The sets that must be empty before a submission runs.
EMPTY = ("CapInh", "CapPrm", "CapEff", "CapAmb")


class CapHeader(ctypes.Structure):
    """``struct __user_cap_header_struct``."""

    _fields_ = [("version", ctypes.c_uint32), ("pid", ctypes.c_int)]


class CapData(ctypes.Structure):
    """``struct __user_cap_data_struct`` (two of them for 64 capabilities)."""

    _fields_ = [("effective", ctypes.c_uint32), ("permitted", ctypes.c_uint32),
                ("inheritable", ctypes.c_uint32)]


def status() -> dict:
    """The capability sets and NoNewPrivs of this process (``/proc/self/status``)."""
    found = {}
    with open("/proc/self/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key.startswith("Cap") or key == "NoNewPrivs":
                found[key] = int(value.strip(), 16 if key.startswith("Cap") else 10)
    return found


def _last_cap() -> int:
    try:
        with open("/proc/sys/kernel/cap_last_cap") as f:
            return int(f.read())
    except (OSError, ValueError):
        return 63


def drop(scratch_uid: bool = True) -> tuple:
    """Give up every capability for good; returns ``(problem, report)``.

    ``problem`` is "" when the process has no capability and no new privileges, else what is
    left; ``report`` lists what holds (for the grader's log of the sandbox layers).
    ``scratch_uid``: move root's real uid to a uid of its own (see the module docstring).
    """
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
        return f"prctl(PR_SET_NO_NEW_PRIVS) failed: {os.strerror(ctypes.get_errno())}", []
    report = ["no-new-privileges"]
    before = status()
    if scratch_uid and os.getuid() == 0 and before.get("CapEff", 0) >> CAP_SETUID & 1:
        uid = SCRATCH_UID_BASE + os.getpid()
        os.setresuid(uid, -1, -1)
        report.append(f"real uid {uid}")
    if before.get("CapEff", 0) >> CAP_SETPCAP & 1:
        libc.prctl(PR_SET_SECUREBITS, SECUREBITS, 0, 0, 0)
        for cap in range(_last_cap() + 1):
            libc.prctl(PR_CAPBSET_DROP, cap, 0, 0, 0)
    libc.prctl(PR_CAP_AMBIENT, PR_CAP_AMBIENT_CLEAR_ALL, 0, 0, 0)
    header, data = CapHeader(LINUX_CAPABILITY_VERSION_3, 0), (CapData * 2)()
    if libc.capset(ctypes.byref(header), data) != 0:
        return f"capset failed: {os.strerror(ctypes.get_errno())}", report
    after = status()
    left = [f"{key}={after.get(key, 0):x}" for key in EMPTY if after.get(key, 0)]
    if left or after.get("NoNewPrivs") != 1:
        return f"capabilities left after dropping them: {', '.join(left) or 'NoNewPrivs=0'}", report
    report.append("no capabilities" + ("" if after.get("CapBnd") else ", empty bounding set"))
    return "", report


def user_tasks(uid: int) -> int:
    """Tasks (threads included) whose real uid is ``uid``: what ``RLIMIT_NPROC`` counts."""
    count = 0
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/status") as f:
                fields = dict(line.split(":", 1) for line in f if ":" in line)
        except (OSError, ValueError):
            continue
        if int(fields.get("Uid", "-1").split()[0]) == uid:
            count += int(fields.get("Threads", "1"))
    return count
