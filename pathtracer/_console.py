"""One line instead of a traceback when Ctrl-C lands while a command is still starting.

``pathtracer`` and ``mitsuba-refs`` import NumPy and SciPy (about 0.3 s) before their ``main``
can catch an interrupt, which would then end in a Python traceback. Imported first by both
packages, this module makes such an interrupt print one line; Python then ends the process by
SIGINT, which shells report as exit status 130. Only in those two commands: a program that
imports the packages keeps Python's own behaviour.
"""
import os
import sys

COMMANDS = ("pathtracer", "mitsuba-refs")


def _one_line_for_interrupts(kind, value, traceback):
    if issubclass(kind, KeyboardInterrupt):
        sys.stderr.write(f"{os.path.basename(sys.argv[0])}: interrupted\n")
        return
    _python_hook(kind, value, traceback)


if sys.argv and os.path.basename(sys.argv[0]) in COMMANDS:
    _python_hook = sys.excepthook
    sys.excepthook = _one_line_for_interrupts
