"""The name a report gives an external renderer: ``--name``, else a short form of its command.

The first word of a template is often not the renderer: ``nice -n 10 ./smallpt ...``,
``env OMP_NUM_THREADS=2 ./render ...``, ``python examples/cycles/render.py ...``. The short
form skips what runs *around* a renderer (variable assignments, process wrappers and their
options) and, for an interpreter, names its script or module:

=================================================  =====================
``nice -n 10 ./bin/smallpt --spp {spp} ...``       ``smallpt``
``OMP_NUM_THREADS=2 timeout 60 mitsuba -m ...``    ``mitsuba``
``python -m pathtracer.cli render ...``            ``pathtracer``
``python3 examples/cycles/render.py ...``          ``cycles-render``
``sh -c './a.out {out}'``                          ``a.out``
=================================================  =====================
"""
from __future__ import annotations

import re
import shlex
from pathlib import PurePosixPath

from ..errors import RefsInputError

#: Programs that run another program: skipped, with their options.
WRAPPERS = frozenset({"nice", "env", "time", "timeout", "taskset", "ionice", "stdbuf", "chrt",
                      "numactl", "nohup", "exec", "command", "setsid", "xvfb-run", "unbuffer",
                      "prlimit", "systemd-run", "firejail", "srun", "mpirun", "mpiexec"})
#: Wrapper options followed by a value (``env -u NAME``, ``timeout -s KILL``).
VALUE_OPTIONS = frozenset({"-u", "-C", "-S", "-s", "-k", "-n", "-c", "-p", "-N", "-m", "-l",
                           "--unset", "--chdir", "--signal", "--kill-after", "--adjustment"})
#: Shells whose ``-c STRING`` is the real command.
SHELLS = frozenset({"sh", "bash", "dash", "zsh"})
#: Interpreters whose script (or ``-m`` module) is the renderer.
INTERPRETERS = re.compile(r"^(python[0-9.]*|pypy[0-9.]*|node|ruby|perl|julia|Rscript|blender)$")
#: Script names that say nothing alone: the folder above them joins the name.
GENERIC_SCRIPTS = frozenset({"render", "main", "run", "cli", "__main__", "app", "renderer"})
#: A wrapper's argument that is not a program: numbers, durations, CPU masks and lists.
_WRAPPER_ARGUMENT = re.compile(r"^[+-]?[0-9][0-9A-Fa-fx.,:smhd-]*$")
_ASSIGNMENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*=")
#: Longest name a report prints.
MAX_NAME = 40


def short_name(command: str) -> str:
    """The renderer's name in a report, from its command template (module docstring)."""
    try:
        words = shlex.split(command)
    except ValueError:                 # an unbalanced quote: the first words still tell
        words = command.split()
    words = _skip_wrappers(words)
    if not words:
        return "renderer"
    program = PurePosixPath(words[0]).name
    if program in SHELLS and "-c" in words[1:-1]:
        return short_name(words[words.index("-c") + 1])
    if INTERPRETERS.match(program):
        return _script_name(words[1:]) or program
    return _clip(program)


def checked_name(name: str) -> str:
    """A ``--name`` as given, refused in one line when it cannot head a report."""
    text = str(name).strip()
    if not text or any(ch in text for ch in "\n\r\t") or len(text) > MAX_NAME:
        raise RefsInputError(f"--name {name!r}: give 1 to {MAX_NAME} characters on one line")
    return text


def _skip_wrappers(words: list) -> list:
    """``words`` without the leading assignments, wrappers and the wrappers' options."""
    index, wrapped = 0, False
    while index < len(words):
        word = words[index]
        name = PurePosixPath(word).name
        if _ASSIGNMENT.match(word) or name in WRAPPERS:
            wrapped = wrapped or name in WRAPPERS
        elif wrapped and word in VALUE_OPTIONS:
            index += 1                     # the option's value is not the program either
        elif not (wrapped and (word.startswith("-") or _WRAPPER_ARGUMENT.match(word))):
            break
        index += 1
    return words[index:]


def _script_name(arguments: list) -> str | None:
    """The script or ``-m`` module an interpreter runs, or None when there is none."""
    for index, word in enumerate(arguments):
        if word == "-m" and index + 1 < len(arguments):
            parts = [part for part in arguments[index + 1].split(".")
                     if part not in GENERIC_SCRIPTS]
            return _clip(parts[0]) if parts else None
        if word in ("-c", "-e"):
            return None
        if not word.startswith("-"):
            path = PurePosixPath(word)
            if path.stem in GENERIC_SCRIPTS and path.parent.name:
                return _clip(f"{path.parent.name}-{path.stem}")
            return _clip(path.stem or path.name)
    return None


def _clip(name: str) -> str:
    return name if len(name) <= MAX_NAME else name[:MAX_NAME - 1] + "\u2026"
