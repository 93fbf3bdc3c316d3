"""Worker processes that never outlive the render that made them.

A forked worker inherits both ends of the pool's pipes, so when its parent dies it never
sees end-of-file: it would sleep forever, holding the caller's stdout and stderr open.
Three guards prevent that:

* on Linux, ``prctl(PR_SET_PDEATHSIG, SIGKILL)`` asks the kernel to kill the worker when
  the parent dies, however it dies (SIGKILL included);
* a watchdog thread exits the worker when its parent process id changes (the fallback
  where prctl is unavailable, and the race of a parent that died before prctl ran);
* :func:`stop_pool` kills the workers at once when the parent gives up on a render
  (Ctrl-C, SIGTERM, an error), instead of waiting for the units in flight.

Workers ignore SIGINT (a Ctrl-C in a terminal reaches the whole process group: only the
parent reports it) and take SIGTERM's default action (no Python handler, no traceback).
:func:`signals_blocked` closes the window between fork and the worker's initializer, in
which a worker would still run the parent's handlers.
"""
from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import os
import signal
import threading
import time

#: ``PR_SET_PDEATHSIG`` from <linux/prctl.h>.
PR_SET_PDEATHSIG = 1
#: Seconds between two checks of the parent's liveness.
WATCHDOG_PERIOD = 0.5
#: Signals a worker must not receive before its initializer has set them up.
_SPAWN_BLOCKED = {signal.SIGINT, signal.SIGTERM}


def set_parent_death_signal(sig: int = signal.SIGKILL) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies (Linux only).

    Returns
    -------
    bool
        Whether the request was accepted (False off Linux or without libc's ``prctl``).
    """
    if not os.uname().sysname == "Linux":
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        return libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


def start_parent_watchdog(parent_pid: int, period: float = WATCHDOG_PERIOD) -> threading.Thread:
    """Exit this process (status 1, no cleanup) as soon as its parent is no longer ``parent_pid``."""
    def watch():
        while os.getppid() == parent_pid:
            time.sleep(period)
        os._exit(1)

    thread = threading.Thread(target=watch, name="parent-watchdog", daemon=True)
    thread.start()
    return thread


def init_worker(parent_pid: int) -> None:
    """First thing a forked worker runs: tie its life to ``parent_pid``, set up signals."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    set_parent_death_signal()
    if os.getppid() != parent_pid:   # the parent died before prctl took effect
        os._exit(1)
    start_parent_watchdog(parent_pid)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _SPAWN_BLOCKED)


@contextlib.contextmanager
def signals_blocked():
    """Block SIGINT and SIGTERM in this thread while workers are forked.

    Children inherit the mask, so none runs the parent's handlers before
    :func:`init_worker`; a signal that arrives meanwhile is delivered to the parent
    when the block ends.
    """
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, _SPAWN_BLOCKED)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def stop_pool(pool) -> None:
    """Kill a ``ProcessPoolExecutor``'s workers now and shut it down without waiting for work."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        with contextlib.suppress(Exception):
            process.kill()
    pool.shutdown(wait=True, cancel_futures=True)
