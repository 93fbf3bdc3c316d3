"""Landlock: the student process may read a few folders and write nothing, whatever its user.

Landlock (Linux 5.13 and later, when the kernel enables it) lets an unprivileged process
give up file-system access for good: after :func:`restrict`, every path the process opens
must lie beneath one of the rules, and the rules here grant reading only. No file may be
written, created, removed, renamed, linked or truncated anywhere (files already open, such
as stdout and the reply pipe, stay usable), which holds for root without capabilities and
for the grader's own user alike, where the permission bits would allow everything the
grader may do. The same domain also forbids ptrace and ``/proc/<pid>/mem`` of any process
outside it (from ABI 1), signals to processes outside it (ABI 6) and TCP (ABI 4).

The ABI version decides which rights exist; :func:`abi` asks the kernel
(``landlock_create_ruleset(NULL, 0, LANDLOCK_CREATE_RULESET_VERSION)``). The call numbers
444-446 are the same on every architecture.
"""
from __future__ import annotations

import ctypes
import os
import stat

CREATE_RULESET, ADD_RULE, RESTRICT_SELF = 444, 445, 446
CREATE_RULESET_VERSION = 1
RULE_PATH_BENEATH = 1

# File-system rights (include/uapi/linux/landlock.h) and the ABI that introduced them.
EXECUTE, WRITE_FILE, READ_FILE, READ_DIR = 1 << 0, 1 << 1, 1 << 2, 1 << 3
REFER, TRUNCATE, IOCTL_DEV = 1 << 13, 1 << 14, 1 << 15
FS_RIGHTS = {1: (1 << 13) - 1, 2: REFER, 3: TRUNCATE, 5: IOCTL_DEV}
NET_BIND_TCP, NET_CONNECT_TCP = 1, 2            # ABI 4
SCOPE_ABSTRACT_UNIX_SOCKET, SCOPE_SIGNAL = 1, 2  # ABI 6
#: Rights a rule may grant on a regular file (the others concern folders).
FILE_RIGHTS = EXECUTE | WRITE_FILE | READ_FILE | TRUNCATE | IOCTL_DEV


class RulesetAttr(ctypes.Structure):
    """``struct landlock_ruleset_attr`` (fields after ``handled_access_fs`` from ABI 4 and 6)."""

    _fields_ = [("handled_access_fs", ctypes.c_uint64), ("handled_access_net", ctypes.c_uint64),
                ("scoped", ctypes.c_uint64)]


class PathBeneathAttr(ctypes.Structure):
    """``struct landlock_path_beneath_attr`` (packed)."""

    _pack_ = 1
    _fields_ = [("allowed_access", ctypes.c_uint64), ("parent_fd", ctypes.c_int32)]


def _libc():
    libc = ctypes.CDLL(None, use_errno=True)
    libc.syscall.restype = ctypes.c_long
    return libc


def abi() -> int:
    """The kernel's Landlock ABI version, or 0 when it has none (or refuses it)."""
    try:
        version = _libc().syscall(CREATE_RULESET, None, ctypes.c_size_t(0),
                                  ctypes.c_uint32(CREATE_RULESET_VERSION))
    except (OSError, AttributeError):
        return 0
    return max(int(version), 0)


def handled_fs(version: int) -> int:
    """Every file-system right that ABI ``version`` knows (all of them are restricted)."""
    return sum(bits for since, bits in FS_RIGHTS.items() if version >= since)


def restrict(readable, listable=(), version: int | None = None) -> str:
    """Let this process read only beneath ``readable`` (paths) and write nowhere.

    Folders in ``listable`` may be listed (and the folders beneath them), not read: the
    files in them stay closed unless ``readable`` names them.

    Must run single-threaded (a ruleset binds the calling thread and the threads it starts
    later) and after ``PR_SET_NO_NEW_PRIVS``. Paths that do not exist are skipped.

    Returns
    -------
    str
        "" once the process is restricted, else why not (the process is then unchanged).
    """
    version = abi() if version is None else version
    if version < 1:
        return "Landlock is not available in this kernel"
    if len(os.listdir("/proc/self/task")) != 1:
        return "Landlock needs a single-threaded process here"
    handled = handled_fs(version)
    attr = RulesetAttr(handled, NET_BIND_TCP | NET_CONNECT_TCP if version >= 4 else 0,
                       SCOPE_ABSTRACT_UNIX_SOCKET | SCOPE_SIGNAL if version >= 6 else 0)
    libc = _libc()
    ruleset = libc.syscall(CREATE_RULESET, ctypes.byref(attr), ctypes.c_size_t(ctypes.sizeof(attr)),
                           ctypes.c_uint32(0))
    if ruleset < 0:
        return f"landlock_create_ruleset failed: {os.strerror(ctypes.get_errno())}"
    try:
        rules = [(path, READ_FILE | READ_DIR) for path in readable]
        rules += [(path, READ_DIR) for path in listable]
        for path, rights in rules:
            try:
                fd = os.open(path, os.O_PATH | os.O_CLOEXEC)
            except OSError:
                continue
            try:
                folder = stat.S_ISDIR(os.fstat(fd).st_mode)
                if not folder and not rights & READ_FILE:
                    continue
                rule = PathBeneathAttr(rights & handled & (~0 if folder else FILE_RIGHTS), fd)
                if libc.syscall(ADD_RULE, ctypes.c_int(ruleset), ctypes.c_int(RULE_PATH_BENEATH),
                                ctypes.byref(rule), ctypes.c_uint32(0)) != 0:
                    return f"landlock_add_rule({path}) failed: {os.strerror(ctypes.get_errno())}"
            finally:
                os.close(fd)
        if libc.syscall(RESTRICT_SELF, ctypes.c_int(ruleset), ctypes.c_uint32(0)) != 0:
            return f"landlock_restrict_self failed: {os.strerror(ctypes.get_errno())}"
    finally:
        os.close(ruleset)
    return ""
