"""Hostile: reads the grader's memory, where the references it compares against are loaded:
``/proc/<grader>/mem`` at the addresses ``/proc/<grader>/maps`` lists, ``process_vm_readv``,
a ptrace seize, ``/proc/<grader>/environ`` and a grader file descriptor taken with
``pidfd_getfd``.

Before the grader made itself non-dumpable this worked between two processes of one user
(the kernel here has no Yama restriction) and, as root without a student user, always.
EXPECT: every way is refused (the grader is not dumpable; the child has no capabilities, a
Landlock domain of its own and a seccomp filter without ptrace, process_vm_* and pidfd_*);
the submission returns black: zero points.
"""
import ctypes
import os

from _hostile import Escaped, black, grader_pids, libc, registry

EXPECT = dict(kind="black", words="")
PTRACE_SEIZE, PTRACE_DETACH = 0x4206, 17


class IoVec(ctypes.Structure):
    _fields_ = [("base", ctypes.c_void_p), ("length", ctypes.c_size_t)]


def read(c, path, offset=0, size=4096):
    """Bytes of ``path`` at ``offset`` through libc (no audit hook sees it); None if refused,
    b"" if opened but unreadable there."""
    fd = c.open(path.encode(), os.O_RDONLY)
    if fd < 0:
        return None
    buffer = ctypes.create_string_buffer(size)
    n = c.pread(fd, buffer, ctypes.c_size_t(size), ctypes.c_long(offset))
    c.close(fd)
    return buffer.raw[:max(n, 0)]


def regions(c, pid):
    """Readable regions of ``pid``, from its maps, or a few guesses when maps are closed."""
    maps = read(c, f"/proc/{pid}/maps", 0, 1 << 20)
    if maps:
        spans = [line.split()[0].split(b"-") for line in maps.splitlines() if b" r" in line]
        return [(int(a, 16), int(b, 16)) for a, b in spans][:200]
    return [(0x400000, 0x401000), (0x555555554000, 0x555555555000)]


def attack(pid):
    c = libc()
    c.pread.restype = ctypes.c_ssize_t
    if read(c, f"/proc/{pid}/mem", 0, 1) is not None:
        for start, _ in regions(c, pid):
            if read(c, f"/proc/{pid}/mem", start, 64):
                raise Escaped(f"LEAK: read /proc/{pid}/mem at {start:#x}")
        raise Escaped(f"LEAK: opened /proc/{pid}/mem (the ptrace access check let us in)")
    buffer = ctypes.create_string_buffer(64)
    for start, _ in regions(c, pid)[:20]:
        local, remote = IoVec(ctypes.addressof(buffer), 64), IoVec(start, 64)
        if c.process_vm_readv(pid, ctypes.byref(local), 1, ctypes.byref(remote), 1, 0) > 0:
            raise Escaped(f"LEAK: process_vm_readv of the grader at {start:#x}")
    if c.ptrace(PTRACE_SEIZE, pid, None, None) == 0:
        c.ptrace(PTRACE_DETACH, pid, None, None)
        raise Escaped(f"LEAK: ptrace-seized the grader {pid}")
    if read(c, f"/proc/{pid}/environ", 0, 16) is not None:
        raise Escaped(f"LEAK: opened /proc/{pid}/environ")
    pidfd = c.syscall(434, pid, 0)                    # pidfd_open (x86-64 and aarch64)
    if pidfd >= 0:
        for target in range(3, 64):
            if c.syscall(438, pidfd, target, 0) >= 0:  # pidfd_getfd
                raise Escaped(f"LEAK: took the grader's file descriptor {target}")


def radiance(self, scene, rays, rng):
    for pid in grader_pids():
        attack(pid)
    return black(rays)


INTEGRATORS = registry(radiance)
