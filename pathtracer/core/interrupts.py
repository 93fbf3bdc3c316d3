"""Ctrl-C remembered, so that a reader never mistakes an interrupt for a bad file.

Python raises ``KeyboardInterrupt`` wherever SIGINT lands. When it lands inside a C++
extension that calls back into Python while reading a file (OpenEXR's reader, Pillow), the
extension may turn it into an error of its own (OpenEXR: "initialization failed"), and a
reader that catches errors would report a sound file as corrupt, or schedule a rebuild of
a valid reference. The commands install :func:`remember` as their SIGINT handler: it counts
the interrupt, then raises as Python's own handler does. A reader records :func:`count`
before it reads and, on an error, calls :func:`reraise_if_interrupted`.
"""
from __future__ import annotations

import signal
import threading

_interrupts = 0


def remember(signum, frame):
    """SIGINT handler: count the interrupt, then raise ``KeyboardInterrupt`` (Python's own)."""
    global _interrupts
    _interrupts += 1
    raise KeyboardInterrupt


def install() -> bool:
    """Use :func:`remember` for SIGINT where Python's default handler is in place (the main
    thread of a command); returns whether it is installed. Another handler stays."""
    if threading.current_thread() is not threading.main_thread():
        return signal.getsignal(signal.SIGINT) is remember
    if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
        signal.signal(signal.SIGINT, remember)
    return signal.getsignal(signal.SIGINT) is remember


def count() -> int:
    """How many interrupts :func:`remember` has seen in this process."""
    return _interrupts


def reraise_if_interrupted(before: int, error: BaseException) -> None:
    """Raise ``KeyboardInterrupt`` (from ``error``) if an interrupt arrived since :func:`count`
    returned ``before``: the error was the interrupt, not the file's."""
    if _interrupts != before:
        raise KeyboardInterrupt from error
