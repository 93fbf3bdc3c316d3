"""The student process's seccomp filter: an allowlist, everything else refused.

The kernel checks every system call of the process (and of its threads) against a small
classic-BPF program built here from :mod:`.syscalls`, so no Python trick inside the process
can undo it:

=====================================  ======================================================
system call                            verdict
=====================================  ======================================================
``syscalls.ALLOWED``                   allowed (memory, reading open files and metadata,
                                       threads' futexes, signals, time, getpid ...)
``clone``                              only with CLONE_THREAD and no namespace flag (threads;
                                       no processes)
``kill`` / ``tgkill``                  only to itself (``kill(0)``: its own process group,
                                       which is itself: it cannot fork)
``prlimit64``                          only on itself (pid 0 or its own)
``open`` / ``openat``                  only read-only: ``EACCES`` with O_WRONLY, O_RDWR,
                                       O_CREAT, O_TRUNC or O_APPEND
``ioctl`` / ``fcntl``                  only the few commands listed in ``syscalls.FILTERED``
``clone3``, ``openat2``                ``ENOSYS`` (glibc falls back to clone / openat)
a call of another architecture         the process is killed (an i386 ``int 0x80`` on
                                       x86-64); x32 calls answer ``ENOSYS``
anything else                          ``EPERM``: no fork, exec, ptrace, process_vm_*,
                                       open_by_handle_at, pipes, sockets, memfd, io_uring,
                                       bpf, mount, unshare, setuid, prctl, mlock ...
=====================================  ======================================================

Output already open (stdout, stderr and the reply pipe) stays writable. x86-64 and aarch64
are supported; :func:`install` returns the reason elsewhere (the child then refuses to run
a submission).
"""
from __future__ import annotations

import ctypes
import errno
import os
import platform
import struct

from . import syscalls

# Classic BPF opcodes and seccomp return values.
LD_ABS = 0x20          # BPF_LD | BPF_W | BPF_ABS
JEQ = 0x15             # BPF_JMP | BPF_JEQ | BPF_K
JGE = 0x35             # BPF_JMP | BPF_JGE | BPF_K
JSET = 0x45            # BPF_JMP | BPF_JSET | BPF_K
RET = 0x06             # BPF_RET | BPF_K
ALLOW = 0x7FFF0000
KILL_PROCESS = 0x80000000
X32_BIT = 0x40000000
# Offsets in struct seccomp_data: nr, arch, then the low 32 bits of args[i] (little-endian;
# every argument checked here is an int the kernel truncates to 32 bits).
NR_OFFSET, ARCH_OFFSET = 0, 4


def _arg(i: int) -> int:
    return 16 + 8 * i


def _errno(code: int) -> int:
    return 0x00050000 | code


def _one_of(values) -> list:
    """Allow when the accumulator is one of ``values``, else EPERM."""
    n = len(values)
    body = [(JEQ, n - i, 0, value) for i, value in enumerate(values)]
    return body + [(RET, 0, 0, _errno(errno.EPERM)), (RET, 0, 0, ALLOW)]


def _check(rule, pid: int) -> list:
    """Instructions that decide a call from its argument (``syscalls.FILTERED`` rule)."""
    index, what = rule
    body = [(LD_ABS, 0, 0, _arg(index))]
    if what == "thread":
        return body + [(JSET, 1, 0, syscalls.CLONE_NAMESPACES), (JSET, 1, 0, syscalls.CLONE_THREAD),
                       (RET, 0, 0, _errno(errno.EPERM)), (RET, 0, 0, ALLOW)]
    if what == "read-only":
        return body + [(JSET, 0, 1, syscalls.WRITE_FLAGS), (RET, 0, 0, _errno(errno.EACCES)),
                       (RET, 0, 0, ALLOW)]
    return body + _one_of([pid if value == "self" else value for value in what])


def program(pid: int, machine: str | None = None) -> list:
    """The filter as (code, jt, jf, k) instructions for a process whose pid is ``pid``."""
    machine = machine or platform.machine()
    arch, table = syscalls.ARCHITECTURES[machine]
    p = [(LD_ABS, 0, 0, ARCH_OFFSET), (JEQ, 1, 0, arch), (RET, 0, 0, KILL_PROCESS),
         (LD_ABS, 0, 0, NR_OFFSET)]
    if table is syscalls.X86_64:
        p += [(JGE, 0, 1, X32_BIT), (RET, 0, 0, _errno(errno.ENOSYS))]
    for name in syscalls.ALLOWED:
        if name in table:
            p += [(JEQ, 0, 1, table[name]), (RET, 0, 0, ALLOW)]
    for name, rule in syscalls.FILTERED.items():
        if name in table:
            body = _check(rule, pid)
            # Each block ends in a return, so the accumulator only changes inside it.
            p += [(JEQ, 0, len(body), table[name])] + body
    for name in syscalls.UNIMPLEMENTED:
        p += [(JEQ, 0, 1, table[name]), (RET, 0, 0, _errno(errno.ENOSYS))]
    p.append((RET, 0, 0, _errno(errno.EPERM)))
    return p


def supported() -> str:
    """"" where the filter can be built, else why not."""
    if platform.system() != "Linux" or platform.machine() not in syscalls.ARCHITECTURES:
        return (f"the grading sandbox's seccomp filter exists for Linux on x86-64 and aarch64 "
                f"only, not {platform.system()} {platform.machine()}")
    if struct.pack("=I", 1) != struct.pack("<I", 1):
        return "the grading sandbox's seccomp filter is written for little-endian machines"
    return ""


def install() -> str:
    """Install the filter on this process; returns "" on success, else why not."""
    reason = supported()
    if reason:
        return reason
    instructions = program(os.getpid())
    raw = b"".join(struct.pack("=HBBI", *ins) for ins in instructions)
    buffer = ctypes.create_string_buffer(raw, len(raw))

    class SockFprog(ctypes.Structure):
        _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]

    fprog = SockFprog(len(instructions), ctypes.addressof(buffer))
    libc = ctypes.CDLL(None, use_errno=True)
    PR_SET_NO_NEW_PRIVS, SECCOMP_SET_MODE_FILTER, FILTER_FLAG_TSYNC = 38, 1, 1
    if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
        return f"prctl(PR_SET_NO_NEW_PRIVS) failed: {os.strerror(ctypes.get_errno())}"
    # TSYNC: every thread of the process gets the filter, not only the calling one.
    if libc.syscall(syscalls.numbers(platform.machine())["seccomp"], SECCOMP_SET_MODE_FILTER,
                    FILTER_FLAG_TSYNC, ctypes.byref(fprog)) != 0:
        return f"seccomp(SECCOMP_SET_MODE_FILTER) failed: {os.strerror(ctypes.get_errno())}"
    return ""
