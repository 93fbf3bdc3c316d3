"""Gradescope ``results.json``: kept in memory, written atomically after every test.

Format (https://gradescope-autograders.readthedocs.io/en/latest/specs/)::

    {"score": 42.0, "execution_time": 97.3, "output": "...", "visibility": "visible",
     "stdout_visibility": "hidden",
     "tests": [{"name": ..., "score": ..., "max_score": ..., "status": "passed"|"failed",
                "output": ..., "visibility": "visible"|"after_due_date"|"hidden"|...}]}

At collection every test is entered with score 0 and "not run"; each finished test replaces
its entry and the whole file is rewritten (temp file + ``os.replace``), so whatever stops the
grader (the platform's timeout, a crash of the grader itself) leaves a valid file whose
score counts the tests finished so far.

The file is written through a descriptor of its folder that the grader opens at its first
write and keeps (no child inherits it): a folder renamed or replaced by a link later does
not move the grader's writes. A write that fails raises :class:`ResultsError`, whose message
is one line (the plugin prints it and exits non-zero; it is never a traceback).
"""
from __future__ import annotations

import errno
import json
import os
import time

VISIBILITIES = ("visible", "after_due_date", "after_published", "hidden")
#: What a test that has not finished says.
NOT_RUN = "not run: the grader stopped before this test"
NOT_RUN_INTERRUPTED = "not run: grading was interrupted before this test finished"
#: The top-level output of an interrupted grading.
INTERRUPTED = ("INTERRUPTED: grading stopped (Ctrl-C or SIGINT) before every test had run; these "
               "scores are not a grade: grade the submission again")
#: Longest output kept per test (Gradescope shows it as text).
MAX_OUTPUT = 8000


class ResultsError(Exception):
    """The results file could not be written (a one-line message)."""


class Results:
    """A results file being filled in."""

    def __init__(self, path: str, output: str = ""):
        self.path = os.path.abspath(path)
        self.start = time.monotonic()
        self.tests = {}
        self.output = output
        self._folder = None

    def add_pending(self, key, name, max_score, visibility="visible"):
        self.tests[key] = dict(name=name, score=0.0, max_score=float(max_score), status="failed",
                               output=NOT_RUN, visibility=visibility)

    def interrupted(self) -> None:
        """Grading was interrupted (Ctrl-C, SIGINT): the file says so and is no grade; the
        tests that had not finished say they were interrupted, not that they failed."""
        self.output = INTERRUPTED
        for test in self.tests.values():
            if test["output"] == NOT_RUN:
                test["output"] = NOT_RUN_INTERRUPTED

    def record(self, key, name, score, max_score, passed, output, visibility="visible"):
        if visibility not in VISIBILITIES:
            raise ValueError(f"visibility must be one of {VISIBILITIES}, got {visibility!r}")
        if len(output) > MAX_OUTPUT:
            output = output[:MAX_OUTPUT] + "\n... (truncated)"
        self.tests[key] = dict(name=name, score=round(float(score), 4),
                               max_score=float(max_score),
                               status="passed" if passed else "failed", output=output,
                               visibility=visibility)
        self.write()

    @property
    def score(self) -> float:
        return round(sum(t["score"] for t in self.tests.values()), 4)

    @property
    def max_score(self) -> float:
        return sum(t["max_score"] for t in self.tests.values())

    def document(self) -> dict:
        return {"score": self.score,
                "execution_time": round(time.monotonic() - self.start, 1),
                "output": self.output or f"{self.score:g} / {self.max_score:g} points",
                "visibility": "visible",
                "stdout_visibility": "hidden",
                "tests": list(self.tests.values())}

    def write(self) -> None:
        """Atomic rewrite: a reader sees the old file or the new one, never a partial one.

        Raises
        ------
        ResultsError
            The file could not be written (one line: the path and the system's reason).
        """
        try:
            self._write()
        except OSError as error:
            reason = error.strerror or str(error)
            raise ResultsError(f"autograder: cannot write the results file {self.path}: {reason}"
                               + (" (is the file immutable? see lsattr)"
                                  if error.errno == errno.EPERM else "")) from None

    def _write(self) -> None:
        if self._folder is None:
            directory = os.path.dirname(self.path) or "."
            os.makedirs(directory, exist_ok=True)
            self._folder = os.open(directory, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
        name = os.path.basename(self.path)
        tmp = f".results-{os.getpid()}-{time.monotonic_ns()}.json"
        data = json.dumps(self.document(), indent=1).encode()
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o644,
                     dir_fd=self._folder)
        try:
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(fd, view):]
                os.fsync(fd)
                os.fchmod(fd, 0o644)
            finally:
                os.close(fd)
            os.replace(tmp, name, src_dir_fd=self._folder, dst_dir_fd=self._folder)
        except BaseException:
            try:
                os.unlink(tmp, dir_fd=self._folder)
            except OSError:
                pass
            raise


def validate(document: dict) -> None:
    """Raise ValueError unless ``document`` is a well-formed Gradescope results object."""
    if not isinstance(document.get("tests"), list):
        raise ValueError("tests must be a list")
    total = 0.0
    for t in document["tests"]:
        for key in ("name", "score", "max_score", "status", "output", "visibility"):
            if key not in t:
                raise ValueError(f"test entry without {key!r}: {t}")
        if t["status"] not in ("passed", "failed"):
            raise ValueError(f"bad status {t['status']!r}")
        if t["visibility"] not in VISIBILITIES:
            raise ValueError(f"bad visibility {t['visibility']!r}")
        if not 0 <= t["score"] <= t["max_score"] + 1e-9:
            raise ValueError(f"score {t['score']} outside [0, {t['max_score']}]")
        total += t["score"]
    if abs(document.get("score", total) - total) > 1e-6:
        raise ValueError(f"score {document['score']} != sum of tests {total}")
