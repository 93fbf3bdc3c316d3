"""Hostile: makes every system call outside the sandbox's allowlist (every number from 0 to
599 that ``grading_child.syscalls`` does not allow, with zero arguments, but the two that the
kernel never filters and that only kill their caller), the allowed calls
in their forbidden forms (a fork through ``clone``, signals and ``prlimit64`` to other
processes, opening for writing, ``FS_IOC_SETFLAGS``, ``TIOCSTI``, ``F_SETPIPE_SZ``, file
locks) and x32 calls.

EXPECT: each answers EPERM (ENOSYS for clone3, openat2 and x32; EACCES for opening to
write): the filter is a default-deny allowlist; the submission returns black: zero points.
It reports every call that was not refused.
"""
import ctypes
import errno
import os
import platform

from _hostile import Escaped, black, libc, registry

EXPECT = dict(kind="black", words="")
CLONE_THREAD, CLONE_NEWUSER = 0x00010000, 0x10000000
FS_IOC_SETFLAGS, TIOCSTI, F_SETPIPE_SZ, F_SETLK = 0x40086602, 0x5412, 1031, 6


def refused(result, *codes):
    return result == -1 and ctypes.get_errno() in codes


def radiance(self, scene, rays, rng):
    from grading_child import syscalls
    c, machine = libc(), platform.machine()
    table = syscalls.numbers(machine)
    allowed = syscalls.allowed_numbers(machine)
    unimplemented = {table[name] for name in syscalls.UNIMPLEMENTED}
    unfiltered = syscalls.UNFILTERED.get(machine, ())     # they would only SIGILL us
    through = []
    for number in range(600):
        if number in allowed or number in unfiltered:
            continue
        expected = (errno.ENOSYS,) if number in unimplemented else (errno.EPERM,)
        if not refused(c.syscall(number, 0, 0, 0, 0, 0, 0), *expected):
            through.append(f"{number} ({ctypes.get_errno()})")
    grader, flag, call = os.getppid(), ctypes.c_int(0x10), c.syscall
    forms = [
        ("clone (a new process)", lambda: call(table["clone"], 0, 0, 0, 0, 0), errno.EPERM),
        ("clone (a thread in a new user namespace)",
         lambda: call(table["clone"], CLONE_THREAD | CLONE_NEWUSER, 0, 0, 0, 0), errno.EPERM),
        ("kill (the grader)", lambda: call(table["kill"], grader, 0), errno.EPERM),
        ("kill (everyone)", lambda: call(table["kill"], -1, 0), errno.EPERM),
        ("tgkill (the grader)", lambda: call(table["tgkill"], grader, grader, 0), errno.EPERM),
        ("prlimit64 (the grader)", lambda: call(table["prlimit64"], grader, 0, 0, 0), errno.EPERM),
        ("openat (for writing)", lambda: call(table["openat"], -100, b"/dev/null", os.O_WRONLY),
         errno.EACCES),
        ("openat (creating)", lambda: call(table["openat"], -100, b"planted.py",
                                           os.O_RDONLY | os.O_CREAT, 0o644), errno.EACCES),
        ("ioctl FS_IOC_SETFLAGS", lambda: call(table["ioctl"], 1, FS_IOC_SETFLAGS, ctypes.byref(flag)),
         errno.EPERM),
        ("ioctl TIOCSTI", lambda: call(table["ioctl"], 0, TIOCSTI, b"x"), errno.EPERM),
        ("fcntl F_SETPIPE_SZ", lambda: call(table["fcntl"], 1, F_SETPIPE_SZ, 1 << 20), errno.EPERM),
        ("fcntl F_SETLK", lambda: call(table["fcntl"], 1, F_SETLK, 0), errno.EPERM),
    ]
    if "open" in table:
        forms.append(("open (read-write)", lambda: call(table["open"], b"/dev/null", os.O_RDWR),
                      errno.EACCES))
    if machine == "x86_64":
        forms.append(("x32 getpid", lambda: call(0x40000000 | 39), errno.ENOSYS))
    through += [what for what, attempt, code in forms if not refused(attempt(), code)]
    if through:
        raise Escaped(f"ESCAPED: {len(through)} calls not refused: {', '.join(through)}")
    return black(rays)
INTEGRATORS = registry(radiance)
