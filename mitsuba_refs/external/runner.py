"""Runs of an external renderer: in parallel, each timed, bounded and cleaned up.

Every run is one shell command (:class:`~mitsuba_refs.external.template.CommandTemplate`)
started in a session of its own, so that its whole process group (the renderer and anything
it started) is killed with SIGKILL when the run ends, fails, times out or the harness is
interrupted: no render outlives its check. Each run writes into a temporary folder of its
own; its standard error is kept there for the one-line message of a failed run.
"""
from __future__ import annotations

import concurrent.futures
import os
import signal
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import RefsInputError
from .images import ExternalImage

#: How often the waiting main thread wakes (a Ctrl-C is seen within this time).
POLL_SECONDS = 0.1
#: The longest piece of a command quoted in a message.
QUOTED_COMMAND = 160


class RunFailed(RefsInputError):
    """A run of the renderer failed (exit code, timeout, no image): one line naming the command."""


@dataclass
class Run:
    """One render to make: its command and where its files go.

    Attributes
    ----------
    spp, seed : int
        Samples per pixel and seed the command was filled with.
    max_depth : int or None
        The path length it was told (None: not told).
    command : str
        The filled shell command.
    out, out_variance : Path, Path or None
        The image (and variance image) it must write.
    request_seed : int or None
        The comparison's seed of the render this run serves (the render's name there; the
        renderer got ``seed``, :mod:`mitsuba_refs.external.seeding`).
    """

    spp: int
    seed: int
    max_depth: int | None
    command: str
    out: Path
    out_variance: Path | None = None
    request_seed: int | None = None
    seconds: float = 0.0
    cpu_seconds: float = 0.0
    exit_code: int | None = None
    #: The image it wrote, once read.
    image: ExternalImage | None = field(default=None, repr=False)

    def record(self) -> dict:
        """What the reports keep of this run."""
        return {"spp": self.spp, "seed": self.seed, "request_seed": self.request_seed,
                "max_depth": self.max_depth,
                "seconds": round(self.seconds, 4), "cpu_seconds": round(self.cpu_seconds, 4),
                "exit_code": self.exit_code, "command": self.command}

    def describe(self) -> str:
        """The run in a few words, for messages."""
        return f"renderer run (seed {self.seed}, {self.spp} spp)"


def quoted(command: str) -> str:
    """``command``, shortened for a one-line message."""
    return command if len(command) <= QUOTED_COMMAND else command[:QUOTED_COMMAND - 3] + "..."


def last_line(path: Path) -> str:
    """The last non-blank line of a text file (empty when there is none)."""
    try:
        text = path.read_bytes()[-4096:].decode("utf-8", "replace")
    except OSError:
        return ""
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1] if lines else ""


@dataclass
class Runner:
    """Runs commands ``jobs`` at a time, each for at most ``timeout`` seconds.

    Attributes
    ----------
    jobs : int
        Runs at once.
    timeout : float
        Seconds a run may take before it is killed (with its process group).
    cwd : Path
        Working folder of the commands (the user's, so that relative paths work).
    """

    jobs: int
    timeout: float
    cwd: Path = field(default_factory=Path.cwd)
    _groups: set = field(default_factory=set, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def run_all(self, runs: list[Run], progress=None) -> None:
        """Run every one of ``runs``; return when all succeeded; ``progress``
        (:class:`pathtracer.core.progress.Progress`), if given, is told each run done.

        Raises
        ------
        RunFailed
            At the first run that fails (the others are killed).
        KeyboardInterrupt
            When interrupted (every run still going is killed first).
        """
        pool = concurrent.futures.ThreadPoolExecutor(max_workers=max(1, self.jobs))
        pending = {pool.submit(self.run_one, run) for run in runs}
        try:
            while pending:
                done, pending = concurrent.futures.wait(
                    pending, timeout=POLL_SECONDS, return_when=concurrent.futures.FIRST_EXCEPTION)
                for future in done:
                    future.result()          # a failed run raises here
                if progress is not None and done:
                    progress.advance(len(done))
        except BaseException:
            for future in pending:
                future.cancel()
            self.kill_all()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)

    def run_one(self, run: Run) -> None:
        """Start ``run``, wait for it (killing it at the timeout), check it wrote its image."""
        stderr_path = run.out.parent / "stderr.txt"
        start = time.perf_counter()
        with open(stderr_path, "wb") as stderr:
            process = subprocess.Popen(["/bin/sh", "-c", run.command], cwd=self.cwd,
                                       stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                       stderr=stderr, start_new_session=True)
        with self._lock:
            self._groups.add(process.pid)
        timed_out = threading.Event()
        timer = threading.Timer(self.timeout, self._expire, (process.pid, timed_out))
        timer.daemon = True
        timer.start()
        try:
            _, status, usage = os.wait4(process.pid, 0)
        finally:
            timer.cancel()
            self._kill_group(process.pid)     # whatever it left running ends with it
            with self._lock:
                self._groups.discard(process.pid)
        process.returncode = os.waitstatus_to_exitcode(status)
        run.seconds = time.perf_counter() - start
        run.cpu_seconds = usage.ru_utime + usage.ru_stime
        run.exit_code = process.returncode
        if timed_out.is_set():
            raise RunFailed(f"{run.describe()} timed out after {self.timeout:g} s and was killed "
                            f"with its process group: {quoted(run.command)}")
        if process.returncode != 0:
            raise RunFailed(f"{run.describe()} {exit_text(process.returncode)}: "
                            f"{quoted(run.command)}; last stderr line: "
                            f"{last_line(stderr_path) or '(none)'}")
        for path in (run.out, run.out_variance):
            if path is not None and not path.is_file():
                raise RunFailed(f"{run.describe()} exited 0 but wrote no image to {path}: "
                                f"{quoted(run.command)}")

    def _expire(self, pid: int, timed_out: threading.Event) -> None:
        timed_out.set()
        self._kill_group(pid)

    def _kill_group(self, pid: int) -> None:
        try:
            os.killpg(pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass

    def kill_all(self) -> None:
        """SIGKILL every process group this runner started and has not reaped."""
        with self._lock:
            groups = list(self._groups)
        for pid in groups:
            self._kill_group(pid)


def exit_text(code: int) -> str:
    """``exited with code 3`` or ``was killed by SIGSEGV``."""
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"
