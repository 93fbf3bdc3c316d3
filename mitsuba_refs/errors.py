"""Errors of the reference side that a user can fix, each told in one line.

The command line (:mod:`mitsuba_refs.cli.main`) prints such an error as
``mitsuba-refs <command>: error: <message>`` and exits with status 2; any
other exception is a bug and keeps its traceback.
"""

import re


class RefsInputError(ValueError):
    """Bad input to the reference side: a scene file, parameter or option the
    user has to change. The message is one line and names the file."""


class ReferenceUnavailable(RuntimeError):
    """No valid cached reference and Mitsuba cannot render one."""


class CacheNotWritable(RefsInputError, ReferenceUnavailable):
    """A reference has to be (re)rendered but its cache folder cannot be written
    (so it is unavailable too: callers that catch :class:`ReferenceUnavailable` see it)."""


#: Mitsuba prefixes its messages with the C++ source location, e.g. ``[parser.cpp:1718]``.
_SOURCE_TAG = re.compile(r"\[[A-Za-z_]+\.(?:cpp|h|py):\d+\]\s*")
#: Mitsuba's parser names the place of an error as ``At FILE (line L, col C): ...``.
_LOCATION = re.compile(r"At (.+?) \(line (\d+), col (\d+)\):\s*(.*)")


def one_line(text):
    """``text`` with its lines joined by ``"; "`` and runs of blanks collapsed."""
    parts = [" ".join(line.split()) for line in str(text).splitlines()]
    return "; ".join(p for p in parts if p)


def is_mitsuba_error(error):
    """True when ``error`` is a ``RuntimeError`` raised by Mitsuba's C++ core
    (its message carries a ``[file.cpp:line]`` tag)."""
    return isinstance(error, RuntimeError) and bool(_SOURCE_TAG.search(str(error)))


def mitsuba_error_line(error, scene_path):
    """One line saying why Mitsuba could not load or render ``scene_path``.

    Mitsuba's message is kept without its C++ source tags; its "At FILE
    (line L, col C):" becomes ``FILE:L:C:``. Its "unused parameters"
    complaint gets a hint: our parameters reach the file only through
    ``$name`` references, so a literal value (a ``sample_count`` written as a
    number) leaves our ``$spp`` unused.
    """
    message = one_line(_SOURCE_TAG.sub("", str(error)))
    unused = re.findall(r"\$(\w+)=", message)
    if "unused parameters" in message and unused:
        names = ", ".join(f"${name}" for name in unused)
        return (f"{scene_path}: Mitsuba refuses the file: it never uses {names} (is the "
                f"sampler's sample_count a literal number?); declare <default name=\"{unused[0]}\" "
                f"value=\"...\"/> and write value=\"${unused[0]}\" where it belongs")
    located = _LOCATION.match(message)
    if located:
        file, line, column, rest = located.groups()
        return f"{file}:{line}:{column}: Mitsuba cannot load the scene: {rest}"
    return f"{scene_path}: Mitsuba cannot load or render the scene: {message}"
