"""Progress of long work, one helper for both command lines: on a terminal one line redrawn in
place with a bar and the time left; in a pipe or a log file a plain line now and then, never an
escape code. Also :func:`colour_allowed`, the one rule for colour (a terminal, and no
``NO_COLOR``).

Every long piece of work (a reference build, a render, ``check``'s renderer runs, the grader's
checks) counts its units with :meth:`Progress.advance`; the clock and the stream are injected,
so that tests need no waiting.
"""
from __future__ import annotations

import os
import sys
import time

__all__ = ["Progress", "Quiet", "colour_allowed", "duration", "is_terminal"]

#: Seconds between two plain lines in a pipe; work shorter than this prints none.
PIPE_INTERVAL = 10.0
#: Seconds between two redraws of the terminal line.
REDRAW_INTERVAL = 0.2
#: Characters of the terminal bar.
BAR_WIDTH = 24


def is_terminal(stream) -> bool:
    """Whether ``stream`` is a terminal that redraws a line (not a pipe, a file or ``TERM=dumb``)."""
    try:
        return bool(stream.isatty()) and os.environ.get("TERM") != "dumb"
    except (AttributeError, ValueError):      # no isatty, or a closed stream
        return False


def colour_allowed(stream) -> bool:
    """Whether colour codes may be written to ``stream``: a terminal, and ``NO_COLOR`` unset
    (https://no-color.org)."""
    return is_terminal(stream) and not os.environ.get("NO_COLOR")


def duration(seconds: float) -> str:
    """``"8 s"``, ``"3 min 05 s"``, ``"1 h 02 min"``: a time said the way a person reads it."""
    seconds = max(0, int(round(seconds)))
    if seconds < 60:
        return f"{seconds} s"
    if seconds < 3600:
        return f"{seconds // 60} min {seconds % 60:02d} s"
    return f"{seconds // 3600} h {seconds % 3600 // 60:02d} min"


class Progress:
    """Counts ``total`` units of work and shows how far it is, and how long is left.

    Parameters
    ----------
    total : int
        Units of the whole work (samples per pixel, runs, batches).
    label : str
        What is being done, first on every line (``"reference cornell-box path_nee"``).
    unit : str
        Name of a unit (``"spp"``, ``"runs"``).
    stream : file, optional
        Where the lines go (default ``sys.stderr``).
    clock : callable, optional
        Seconds, monotonic (default ``time.monotonic``).
    terminal : bool, optional
        Redraw one line (default: :func:`is_terminal` of ``stream``).
    estimate_after : float, optional
        When the work, at the pace of its first units, will take longer than this many
        seconds, say so once, with ``faster`` (how to make it faster) if given.
    faster : str, optional
        The faster route, for that one line.
    """

    def __init__(self, total, label, unit="", *, stream=None, clock=time.monotonic,
                 terminal=None, estimate_after=None, faster=None):
        self.total, self.label, self.unit = max(1, int(total)), label, unit
        self.stream = sys.stderr if stream is None else stream
        self.clock = clock
        self.terminal = is_terminal(self.stream) if terminal is None else terminal
        self.estimate_after, self.faster = estimate_after, faster
        self.done = 0
        self.start = self.last = clock()
        self.printed = False
        self.estimated = False
        self._width = 0     # of the last line written: a shorter redraw covers it with spaces

    # tqdm's names, so that the render's scheduler takes a Progress where it took a bar.
    def update(self, n: int = 1) -> None:
        self.advance(n)

    def advance(self, n: int = 1) -> None:
        """Count ``n`` more units done; show them if it is time to."""
        self.done = min(self.total, self.done + n)
        now = self.clock()
        self._estimate(now)
        if self.terminal:
            if now - self.last >= REDRAW_INTERVAL or self.done == self.total:
                self._write("\r" + self._bar(now))
                self.last = now
        elif now - self.last >= PIPE_INTERVAL and self.done < self.total:
            self._write(self._line(now) + "\n")
            self.last = now

    def close(self) -> None:
        """End the progress: the terminal line is finished; in a pipe, work that printed a line
        ends with one saying how long it took."""
        elapsed = self.clock() - self.start
        if self.terminal and self.printed:
            self._write("\r" + self._bar(self.clock()) + "\n")
        elif self.printed:
            self._write(f"{self.label}: {self._count()} done in {duration(elapsed)}\n")

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # ---- lines ---------------------------------------------------------------------------
    def _count(self) -> str:
        unit = f" {self.unit}" if self.unit else ""
        return f"{self.done}/{self.total}{unit}"

    def _left(self, now) -> str:
        elapsed = now - self.start
        if self.done == 0:
            return f"{duration(elapsed)} elapsed"
        if self.done == self.total:
            return f"done in {duration(elapsed)}"
        left = elapsed * (self.total - self.done) / self.done
        return f"{duration(elapsed)} elapsed, about {duration(left)} left"

    def _line(self, now) -> str:
        percent = 100 * self.done // self.total
        return f"{self.label}: {self._count()} ({percent}%), {self._left(now)}"

    def _bar(self, now) -> str:
        filled = BAR_WIDTH * self.done // self.total
        bar = "#" * filled + "-" * (BAR_WIDTH - filled)
        text = f"{self.label} [{bar}] {self._count()}, {self._left(now)}"
        return text.ljust(self._width)

    def _write(self, text: str) -> None:
        self._width = len(text.strip("\r\n"))
        self.stream.write(text)
        self.stream.flush()
        self.printed = True

    def _estimate(self, now) -> None:
        """The one line saying how long the whole work will take, when that is long."""
        if self.estimated or self.estimate_after is None or self.done == 0:
            return
        self.estimated = True
        total = (now - self.start) * self.total / self.done
        if total <= self.estimate_after:
            return
        faster = f"; faster: {self.faster}" if self.faster else ""
        prefix = "\n" if self.terminal and self.printed else ""
        self._write(f"{prefix}{self.label}: about {duration(total)} in all at this pace{faster}\n")


class Quiet:
    """A :class:`Progress` that shows nothing (``--no-progress``)."""

    def update(self, n: int = 1) -> None:
        pass

    def advance(self, n: int = 1) -> None:
        pass

    def close(self) -> None:
        pass
