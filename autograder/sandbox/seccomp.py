"""A seccomp filter for the student process: no new processes, no signals to others, no
file writes, no sockets; everything else runs as usual.

The kernel checks every system call of the process (and of its threads) against a small
BPF program built here, so no Python trick inside the process can undo it:

=========================================  =================================================
system call                                verdict
=========================================  =================================================
fork, vfork, clone without CLONE_THREAD    EPERM (threads still work: clone3 answers ENOSYS
                                           and glibc falls back to clone with CLONE_THREAD)
execve, execveat                           EPERM
kill / tgkill to another process           EPERM (to itself, or kill(0): allowed)
tkill, rt_(tg)sigqueueinfo, pidfd_*        EPERM
ptrace, process_vm_readv/writev            EPERM
open/openat/creat for writing              EACCES (O_WRONLY, O_RDWR, O_CREAT, O_TRUNC, O_APPEND)
openat2                                    ENOSYS (its flags live in memory; libc falls back)
unlink, rename, mkdir, chmod, chown,       EACCES
truncate, link, symlink, mknod, utime,
setxattr and their *at variants
socket, socketpair                         EACCES
io_uring_*, bpf, perf_event_open,          EPERM (io_uring would bypass the checks above)
userfaultfd, mount, unshare, setns, ...
=========================================  =================================================

Output already open (stdout, stderr and the reply pipe) stays writable. Only x86-64 is
supported (:func:`install` returns a reason otherwise); numbers from the kernel's
``arch/x86/entry/syscalls/syscall_64.tbl``.
"""
from __future__ import annotations

import ctypes
import errno
import os
import platform
import struct

AUDIT_ARCH_X86_64 = 0xC000003E
CLONE_THREAD = 0x00010000
WRITE_FLAGS = 0o1 | 0o2 | 0o100 | 0o1000 | 0o2000      # O_WRONLY O_RDWR O_CREAT O_TRUNC O_APPEND

# x86-64 system call numbers.
NR = dict(
    open=2, socket=41, socketpair=53, clone=56, fork=57, vfork=58, execve=59, kill=62,
    truncate=76, ftruncate=77, rename=82, mkdir=83, rmdir=84, creat=85, link=86, unlink=87,
    symlink=88, chmod=90, fchmod=91, chown=92, fchown=93, lchown=94, ptrace=101,
    rt_sigqueueinfo=129, utime=132, mknod=133, chroot=161, mount=165, umount2=166,
    setxattr=188, lsetxattr=189, fsetxattr=190, removexattr=197, lremovexattr=198,
    fremovexattr=199, tkill=200, tgkill=234, utimes=235, keyctl=250, openat=257, mkdirat=258,
    mknodat=259, fchownat=260, futimesat=261, unlinkat=263, renameat=264, linkat=265,
    symlinkat=266, fchmodat=268, unshare=272, utimensat=280, rt_tgsigqueueinfo=297,
    perf_event_open=298, setns=308, process_vm_readv=310, process_vm_writev=311,
    renameat2=316, bpf=321, execveat=322, userfaultfd=323, pidfd_send_signal=424,
    io_uring_setup=425, io_uring_enter=426, io_uring_register=427, pidfd_open=434,
    clone3=435, openat2=437, pidfd_getfd=438, fchmodat2=452,
)

DENY = {
    errno.EPERM: ("fork", "vfork", "execve", "execveat", "tkill", "rt_sigqueueinfo",
                  "rt_tgsigqueueinfo", "pidfd_open", "pidfd_send_signal", "pidfd_getfd",
                  "ptrace", "process_vm_readv", "process_vm_writev", "io_uring_setup",
                  "io_uring_enter", "io_uring_register", "bpf", "perf_event_open",
                  "userfaultfd", "keyctl", "mount", "umount2", "chroot", "unshare", "setns"),
    errno.EACCES: ("creat", "truncate", "ftruncate", "rename", "renameat", "renameat2", "mkdir",
                   "mkdirat", "rmdir", "unlink", "unlinkat", "link", "linkat", "symlink",
                   "symlinkat", "chmod", "fchmod", "fchmodat", "fchmodat2", "chown", "fchown",
                   "lchown", "fchownat", "mknod", "mknodat", "utime", "utimes", "utimensat",
                   "futimesat", "setxattr", "lsetxattr", "fsetxattr", "removexattr",
                   "lremovexattr", "fremovexattr", "socket", "socketpair"),
    errno.ENOSYS: ("clone3", "openat2"),
}

# Classic BPF opcodes and seccomp return values.
LD_ABS = 0x20          # BPF_LD | BPF_W | BPF_ABS
JEQ = 0x15             # BPF_JMP | BPF_JEQ | BPF_K
JGE = 0x35             # BPF_JMP | BPF_JGE | BPF_K
JSET = 0x45            # BPF_JMP | BPF_JSET | BPF_K
RET = 0x06             # BPF_RET | BPF_K
ALLOW = 0x7FFF0000
KILL_PROCESS = 0x80000000
# Offsets in struct seccomp_data: nr, arch, then the low 32 bits of args[i] (little-endian).
NR_OFFSET, ARCH_OFFSET = 0, 4


def _arg(i: int) -> int:
    return 16 + 8 * i


def _errno(code: int) -> int:
    return 0x00050000 | code


def program(pid: int) -> list:
    """The filter as (code, jt, jf, k) instructions for a process whose pid is ``pid``."""
    p = [(LD_ABS, 0, 0, ARCH_OFFSET), (JEQ, 1, 0, AUDIT_ARCH_X86_64), (RET, 0, 0, KILL_PROCESS),
         (LD_ABS, 0, 0, NR_OFFSET), (JGE, 0, 1, 0x40000000), (RET, 0, 0, _errno(errno.ENOSYS))]
    for code, names in DENY.items():
        for name in names:
            p += [(JEQ, 0, 1, NR[name]), (RET, 0, 0, _errno(code))]
    # Each block below ends in a return, so the accumulator only changes inside it.
    p += [(JEQ, 0, 4, NR["clone"]), (LD_ABS, 0, 0, _arg(0)), (JSET, 1, 0, CLONE_THREAD),
          (RET, 0, 0, _errno(errno.EPERM)), (RET, 0, 0, ALLOW)]
    p += [(JEQ, 0, 5, NR["kill"]), (LD_ABS, 0, 0, _arg(0)), (JEQ, 2, 0, pid), (JEQ, 1, 0, 0),
          (RET, 0, 0, _errno(errno.EPERM)), (RET, 0, 0, ALLOW)]
    p += [(JEQ, 0, 4, NR["tgkill"]), (LD_ABS, 0, 0, _arg(0)), (JEQ, 1, 0, pid),
          (RET, 0, 0, _errno(errno.EPERM)), (RET, 0, 0, ALLOW)]
    for name, flags_arg in (("open", 1), ("openat", 2)):
        p += [(JEQ, 0, 4, NR[name]), (LD_ABS, 0, 0, _arg(flags_arg)), (JSET, 0, 1, WRITE_FLAGS),
              (RET, 0, 0, _errno(errno.EACCES)), (RET, 0, 0, ALLOW)]
    p.append((RET, 0, 0, ALLOW))
    return p


def install() -> str:
    """Install the filter on this process; returns "" on success, else why not."""
    if platform.system() != "Linux" or platform.machine() not in ("x86_64", "AMD64"):
        return f"seccomp filter not available on {platform.system()} {platform.machine()}"
    instructions = program(os.getpid())
    raw = b"".join(struct.pack("=HBBI", *ins) for ins in instructions)
    buffer = ctypes.create_string_buffer(raw, len(raw))

    class SockFprog(ctypes.Structure):
        _fields_ = [("len", ctypes.c_ushort), ("filter", ctypes.c_void_p)]

    fprog = SockFprog(len(instructions), ctypes.addressof(buffer))
    libc = ctypes.CDLL(None, use_errno=True)
    PR_SET_NO_NEW_PRIVS, SYS_SECCOMP, SECCOMP_SET_MODE_FILTER, FILTER_FLAG_TSYNC = 38, 317, 1, 1
    if libc.prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0:
        return f"prctl(PR_SET_NO_NEW_PRIVS) failed: {os.strerror(ctypes.get_errno())}"
    # TSYNC: every thread of the process gets the filter, not only the calling one.
    if libc.syscall(SYS_SECCOMP, SECCOMP_SET_MODE_FILTER, FILTER_FLAG_TSYNC,
                    ctypes.byref(fprog)) != 0:
        return f"seccomp(SECCOMP_SET_MODE_FILTER) failed: {os.strerror(ctypes.get_errno())}"
    return ""
