"""Mitsuba's log in our output: plain lines (no colour codes, which Mitsuba's own appender
writes even into a pipe; red only on a terminal without ``NO_COLOR``), and without the warning
that Python integrators are slow in scalar variants, which
:func:`mitsuba_refs.reference.render.render_reference` replaces by its own one-line estimate of
the time and the faster route."""
from __future__ import annotations

import re
import sys

from pathtracer.core.progress import colour_allowed

__all__ = ["install", "plain"]

#: The words of Mitsuba's warning about Python integrators in ``scalar_*`` variants.
SLOW_PYTHON_INTEGRATOR = "Python implementations will have terrible performance"
#: ANSI escape sequences (colours, cursor moves).
ANSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")

_installed = []


def plain(text: str) -> str | None:
    """The line of Mitsuba's log message ``text`` as we print it, or None to drop it."""
    if SLOW_PYTHON_INTEGRATOR in text:
        return None
    return "mitsuba: " + ANSI.sub("", text).rstrip()


def install(stream=None) -> None:
    """Replace Mitsuba's log appender by one writing :func:`plain` lines to ``stream``
    (default ``sys.stderr`` at the time of writing); once per process."""
    if _installed:
        return
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders

    class PlainAppender(mi.Appender):
        def append(self, level, text):
            line = plain(text)
            if line is not None:
                out = sys.stderr if stream is None else stream
                if colour_allowed(out) and level in (mi.LogLevel.Warn, mi.LogLevel.Error):
                    line = f"\x1b[31m{line}\x1b[0m"
                out.write(line + "\n")
                out.flush()

        def log_progress(self, progress, name, formatted, eta, ptr=None):
            pass        # Mitsuba's progress bar: ours (pathtracer.core.progress) says it

    logger = mi.logger() if hasattr(mi, "logger") else mi.Thread.thread().logger()
    appender = PlainAppender()
    logger.clear_appenders()
    logger.add_appender(appender)
    _installed.append(appender)     # kept alive: Mitsuba holds only a reference to it
