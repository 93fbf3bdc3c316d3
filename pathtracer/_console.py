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
#: ``python -m MODULE`` -> the command it runs.
MODULES = {"pathtracer": "pathtracer", "mitsuba_refs": "mitsuba-refs"}


def command_name() -> str | None:
    """The command this process runs (``pathtracer``, ``mitsuba-refs``, also as ``python -m``),
    or None when a program merely imports the packages."""
    name = os.path.basename(sys.argv[0]) if sys.argv else ""
    if name in COMMANDS:
        return name
    original = list(getattr(sys, "orig_argv", ()))     # while -m locates the module, argv[0] is "-m"
    if "-m" in original[:-1]:
        return MODULES.get(original[original.index("-m") + 1])
    return None


def _one_line_for_interrupts(kind, value, traceback):
    if issubclass(kind, KeyboardInterrupt):
        sys.stderr.write(f"{_command}: interrupted\n")
        return
    _python_hook(kind, value, traceback)


_command = command_name()
if _command is not None:
    _python_hook = sys.excepthook
    sys.excepthook = _one_line_for_interrupts
