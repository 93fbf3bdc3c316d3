"""Hostile: pins kernel memory outside the address-space limit: pipes grown to 1 MB each
(``F_SETPIPE_SZ``) and filled, memfd files, socket pairs, a SysV shared-memory segment (which
would outlive the process), thousands of open files and of threads with small stacks.

EXPECT: pipes, memfd, sockets and SysV IPC are refused (seccomp), F_SETPIPE_SZ on the pipes
it has is refused, open files stop at the descriptor limit and threads at the task limit;
nothing near the 256 MB the old sandbox let it pin. The submission returns black: zero points.
"""
import ctypes
import fcntl
import os
import threading
import time

from _hostile import Escaped, black, libc, registry

EXPECT = dict(kind="black", words="")
MB = 1 << 20
#: More than this outside RLIMIT_AS (or more files or threads than the limits) is a hole.
PINNED_LIMIT, FILES_LIMIT, THREADS_LIMIT = 4 * MB, 128, 128
F_SETPIPE_SZ = 1031


def pipes(c):
    """Bytes stored in pipes it makes (os.pipe and pipe2 through libc), grown and filled."""
    pinned, ends = 0, []
    try:
        for _ in range(256):
            try:
                r, w = os.pipe()
            except OSError:
                fds = (ctypes.c_int * 2)()
                if c.pipe2(fds, os.O_NONBLOCK) != 0:
                    break
                r, w = fds[0], fds[1]
            ends += [r, w]
            os.set_blocking(w, False)
            try:
                fcntl.fcntl(w, F_SETPIPE_SZ, MB)
            except OSError:
                pass
            try:
                while True:
                    pinned += os.write(w, b"\0" * 65536)
            except OSError:
                pass
            if pinned > PINNED_LIMIT:
                break
    finally:
        for fd in ends:
            os.close(fd)
    return pinned


def memfd(c):
    fd = c.memfd_create(b"pinned", 0)
    if fd < 0:
        return 0
    try:
        return sum(os.write(fd, b"\0" * MB) for _ in range(8))
    except OSError:
        return MB
    finally:
        os.close(fd)


def sockets(c):
    fds = (ctypes.c_int * 2)()
    if c.socketpair(1, 1, 0, fds) != 0:          # AF_UNIX, SOCK_STREAM
        return 0
    os.close(fds[0])
    os.close(fds[1])
    return MB


def shared_memory(c):
    segment = c.shmget(0, 8 * MB, 0o1000 | 0o600)     # IPC_PRIVATE, IPC_CREAT
    if segment < 0:
        return 0
    c.shmctl(segment, 0, None)                       # IPC_RMID: do not leave it behind
    return 8 * MB


def files():
    opened = []
    try:
        for _ in range(4096):
            try:
                opened.append(os.open("/dev/null", os.O_RDONLY))
            except OSError:
                break
        return len(opened)
    finally:
        for fd in opened:
            os.close(fd)


def threads():
    stop, started = threading.Event(), 0
    threading.stack_size(64 * 1024)
    try:
        for _ in range(4096):
            try:
                threading.Thread(target=stop.wait, daemon=True).start()
            except (RuntimeError, OSError):
                break
            started += 1
    finally:
        stop.set()
        threading.stack_size(0)
    time.sleep(0.1)
    return started


def radiance(self, scene, rays, rng):
    c = libc()
    for what, pinned in (("pipes", pipes(c)), ("memfd", memfd(c)), ("sockets", sockets(c)),
                         ("SysV shared memory", shared_memory(c))):
        if pinned > PINNED_LIMIT or (what != "pipes" and pinned):
            raise Escaped(f"ESCAPED: pinned {pinned / MB:.1f} MB of kernel memory in {what}")
    if files() > FILES_LIMIT:
        raise Escaped("ESCAPED: opened more files than the descriptor limit allows")
    if threads() > THREADS_LIMIT:
        raise Escaped("ESCAPED: started more threads than the task limit allows")
    return black(rays)


INTEGRATORS = registry(radiance)
