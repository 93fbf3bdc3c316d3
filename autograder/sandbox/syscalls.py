"""The system calls the student process may make, and their numbers on x86-64 and aarch64.

Copied into the student runtime with :mod:`.seccomp`, which turns these tables into the
kernel filter; a submission may read it (the policy is no secret). Numbers are those of the
kernel's tables: ``arch/x86/entry/syscalls/syscall_64.tbl`` for x86-64 and the generic
``include/uapi/asm-generic/unistd.h`` that arm64 uses (which has no ``open``, ``stat``,
``poll``, ``pipe``, ``fork`` ...: libc calls the ``*at`` and ``p*`` forms there).

How the list was found: the student process ran CPython, NumPy and SciPy under ``strace -f``
after the filter was installed (imports of SciPy's compiled modules after the sandbox
closed, linear algebra, FFT, threads and a thread pool, printing, tracebacks, a caught
``MemoryError``, the reference integrators' renders, the light tracer and the media
integrators), and every call it made is below; a few that the same code makes on other
machines (``clock_gettime`` when the vDSO is not used, ``stat``/``lstat`` of older libcs,
``statx``, ``faccessat2``) were added by reading what CPython and glibc call. Nothing else
is allowed: the filter denies every other call (``EPERM``), whatever its number.
"""
from __future__ import annotations

#: Allowed whatever the arguments (names missing on an architecture are skipped there).
ALLOWED = (
    # memory (anonymous and file mappings; executable mappings too: a native library
    # loaded after the filter is mapped so, and native code gets no call the filter refuses)
    "mmap", "munmap", "mprotect", "mremap", "madvise", "brk", "mbind",
    # files already open, and reading metadata (what may be opened is filtered below)
    "read", "pread64", "readv", "write", "writev", "lseek", "close", "fstat", "newfstatat",
    "stat", "lstat", "statx", "statfs", "fstatfs", "getdents64", "readlink", "readlinkat",
    "access", "faccessat", "faccessat2", "getcwd", "chdir", "fchdir", "dup", "dup2", "dup3",
    "poll", "ppoll", "select", "pselect6",
    # threads (clone itself is filtered below)
    "futex", "set_robust_list", "rseq", "sched_yield", "sched_getaffinity", "gettid",
    # signals to itself (kill and tgkill are filtered below)
    "rt_sigaction", "rt_sigprocmask", "rt_sigreturn", "rt_sigpending", "rt_sigsuspend",
    "rt_sigtimedwait", "sigaltstack", "pause", "alarm", "getitimer", "setitimer",
    "restart_syscall",
    # time
    "clock_gettime", "clock_getres", "clock_nanosleep", "nanosleep", "gettimeofday", "time",
    "times",
    # who and where it is
    "getpid", "getppid", "getuid", "geteuid", "getgid", "getegid", "getresuid", "getresgid",
    "getgroups", "getpgrp", "getpgid", "getsid", "uname", "sysinfo", "getrusage",
    "getrlimit", "getcpu", "getrandom",
    "exit", "exit_group",
)

#: Answered ``ENOSYS``, not ``EPERM``: glibc falls back to an allowed call only on ENOSYS
#: (``clone3`` -> ``clone`` with CLONE_THREAD; ``openat2``, whose flags live in memory
#: where the filter cannot read them, -> ``openat``).
UNIMPLEMENTED = ("clone3", "openat2")

#: Allowed only in a safe form, checked on the call's arguments by :mod:`.seccomp`:
#: name -> (index of the argument checked, what it must be). ``"self"`` is the process's
#: own pid, ``"thread"`` means CLONE_THREAD without namespace flags, ``"read-only"`` no
#: write, create, truncate or append flag; a tuple lists the values accepted.
FILTERED = {
    "clone": (0, "thread"),
    "kill": (0, ("self", 0)),
    "tgkill": (0, ("self",)),
    "prlimit64": (0, ("self", 0)),
    "open": (1, "read-only"),
    "openat": (2, "read-only"),
    # terminal queries isatty() makes, FIONREAD, non-blocking and close-on-exec switches;
    # no FS_IOC_SETFLAGS (immutable files), no TIOCSTI, nothing else
    "ioctl": (1, (0x5401, 0x5413, 0x541B, 0x5421, 0x5450, 0x5451)),
    # F_DUPFD, F_GETFD, F_SETFD, F_GETFL, F_SETFL, F_DUPFD_CLOEXEC; no F_SETPIPE_SZ
    # (kernel memory), no leases, locks, signals on I/O
    "fcntl": (1, (0, 1, 2, 3, 4, 1030)),
}

#: Calls the kernel runs before any seccomp filter sees them (x86-64 ``uretprobe`` 335 from
#: Linux 6.11 and ``uprobe`` 336 from 6.16): made anywhere but from the kernel's probe
#: trampoline, each kills its caller with SIGILL, so they give a submission nothing.
UNFILTERED = {"x86_64": (335, 336)}

CLONE_THREAD = 0x00010000
#: CLONE_NEWNS, CLONE_NEWCGROUP, CLONE_NEWUTS, CLONE_NEWIPC, CLONE_NEWUSER, CLONE_NEWPID,
#: CLONE_NEWNET: refused even with CLONE_THREAD.
CLONE_NAMESPACES = 0x00020000 | 0x02000000 | 0x04000000 | 0x08000000 | 0x10000000 \
    | 0x20000000 | 0x40000000
#: O_WRONLY, O_RDWR, O_CREAT, O_TRUNC, O_APPEND (O_TMPFILE needs O_WRONLY or O_RDWR).
WRITE_FLAGS = 0o1 | 0o2 | 0o100 | 0o1000 | 0o2000

#: x86-64 (``syscall_64.tbl``): every call named above, plus those the hostile zoo and the
#: tests name when they check that a call is refused.
X86_64 = dict(
    read=0, write=1, open=2, close=3, stat=4, fstat=5, lstat=6, poll=7, lseek=8, mmap=9,
    mprotect=10, munmap=11, brk=12, rt_sigaction=13, rt_sigprocmask=14, rt_sigreturn=15,
    ioctl=16, pread64=17, pwrite64=18, readv=19, writev=20, access=21, pipe=22, select=23,
    sched_yield=24, mremap=25, madvise=28, shmget=29, dup=32, dup2=33, pause=34,
    nanosleep=35, getitimer=36, alarm=37, setitimer=38, getpid=39, socket=41, socketpair=53,
    clone=56, fork=57, vfork=58, execve=59, exit=60, kill=62, uname=63, fcntl=72,
    ftruncate=77, getcwd=79, chdir=80, fchdir=81, rename=82, mkdir=83, unlink=87,
    readlink=89, chmod=90, gettimeofday=96, getrlimit=97, getrusage=98, sysinfo=99,
    times=100, ptrace=101, getuid=102, getgid=104, setuid=105, geteuid=107, getegid=108,
    setpgid=109, getppid=110, getpgrp=111, setsid=112, getgroups=115, getresuid=118,
    getresgid=120, getpgid=121, getsid=124, capset=126, rt_sigpending=127,
    rt_sigtimedwait=128, rt_sigqueueinfo=129, rt_sigsuspend=130, sigaltstack=131,
    statfs=137, fstatfs=138, setpriority=141, mlock=149, prctl=157, setrlimit=160,
    chroot=161, mount=165, gettid=186, setxattr=188, tkill=200, time=201, futex=202,
    sched_getaffinity=204, getdents64=217, set_tid_address=218, restart_syscall=219,
    clock_gettime=228, clock_getres=229, clock_nanosleep=230, exit_group=231, tgkill=234,
    mbind=237, openat=257, newfstatat=262, readlinkat=267, faccessat=269, pselect6=270,
    ppoll=271, unshare=272, set_robust_list=273, splice=275, vmsplice=278, eventfd2=290,
    dup3=292, pipe2=293, perf_event_open=298, prlimit64=302, name_to_handle_at=303,
    open_by_handle_at=304, setns=308, getcpu=309, process_vm_readv=310,
    process_vm_writev=311, seccomp=317, getrandom=318, memfd_create=319, bpf=321,
    execveat=322, userfaultfd=323, statx=332, rseq=334, pidfd_send_signal=424,
    io_uring_setup=425, pidfd_open=434, clone3=435, openat2=437, pidfd_getfd=438,
    faccessat2=439, landlock_create_ruleset=444,
)

#: aarch64 (the generic table, 64-bit names: ``fstatat`` is ``newfstatat``, ``fcntl``,
#: ``lseek``, ``mmap``, ``statfs`` their 64-bit forms).
AARCH64 = dict(
    setxattr=5, getcwd=17, eventfd2=19, dup=23, dup3=24, fcntl=25, ioctl=29, mkdirat=34,
    unlinkat=35, renameat=38, mount=40, statfs=43, fstatfs=44, ftruncate=46, faccessat=48,
    chdir=49, fchdir=50, chroot=51, openat=56, close=57, pipe2=59, getdents64=61, lseek=62,
    read=63, write=64, readv=65, writev=66, pread64=67, pwrite64=68, pselect6=72, ppoll=73,
    vmsplice=75, splice=76, readlinkat=78, newfstatat=79, fstat=80, exit=93, exit_group=94,
    set_tid_address=96, unshare=97, futex=98, set_robust_list=99, nanosleep=101,
    getitimer=102, setitimer=103, clock_gettime=113, clock_getres=114, clock_nanosleep=115,
    ptrace=117, sched_getaffinity=123, sched_yield=124, restart_syscall=128, kill=129,
    tkill=130, tgkill=131, sigaltstack=132, rt_sigsuspend=133, rt_sigaction=134,
    rt_sigprocmask=135, rt_sigpending=136, rt_sigtimedwait=137, rt_sigqueueinfo=138,
    rt_sigreturn=139, setpriority=140, setuid=146, getresuid=148, getresgid=150, times=153,
    setpgid=154, getpgid=155, getsid=156, setsid=157, getgroups=158, uname=160,
    getrlimit=163, setrlimit=164, getrusage=165, prctl=167, getcpu=168, gettimeofday=169,
    getpid=172, getppid=173, getuid=174, geteuid=175, getgid=176, getegid=177, gettid=178,
    sysinfo=179, shmget=194, socket=198, socketpair=199, brk=214, munmap=215, mremap=216,
    clone=220, execve=221, mmap=222, mprotect=226, mlock=228, madvise=233, mbind=235,
    perf_event_open=241, prlimit64=261, name_to_handle_at=264, open_by_handle_at=265,
    setns=268, process_vm_readv=270, process_vm_writev=271, seccomp=277, getrandom=278,
    memfd_create=279, bpf=280, execveat=281, userfaultfd=282, statx=291, rseq=293,
    pidfd_send_signal=424, io_uring_setup=425, pidfd_open=434, clone3=435, openat2=437,
    pidfd_getfd=438, faccessat2=439, landlock_create_ruleset=444,
)

#: machine (``platform.machine()``) -> (audit architecture of seccomp_data, numbers).
ARCHITECTURES = {
    "x86_64": (0xC000003E, X86_64),       # AUDIT_ARCH_X86_64
    "aarch64": (0xC00000B7, AARCH64),     # AUDIT_ARCH_AARCH64
}
ARCHITECTURES["AMD64"] = ARCHITECTURES["x86_64"]
ARCHITECTURES["arm64"] = ARCHITECTURES["aarch64"]


def numbers(machine: str) -> dict:
    """``name -> number`` of ``machine``'s calls named here (KeyError when unsupported)."""
    return ARCHITECTURES[machine][1]


def allowed_numbers(machine: str) -> set:
    """Numbers of every call the filter lets through in some form on ``machine``."""
    table = numbers(machine)
    return {table[name] for name in (*ALLOWED, *FILTERED) if name in table}
