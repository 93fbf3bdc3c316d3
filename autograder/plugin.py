"""The autograder's pytest plugin (entry point ``pytest11: autograder``).

Options
-------
``--impl PATH_OR_MODULE``   the implementation to grade (default :mod:`autograder.solution`)
``--assignment NAME``       the assignment graded (:data:`autograder.grading.ASSIGNMENTS`;
                            default ``path-tracing``)
``--gradescope RESULTS``    write Gradescope's ``results.json`` there, after every test
``--grading-pictures DIR``  where z-map pictures of failed checks go (default: next to RESULTS)
``--solution-runtime``      grade in the runtime that contains the reference solution, without
                            the refusal check: for instructors' submissions built on the
                            solution (bug zoo, correct alternatives); never for students

Before the first test, when the student's code runs as its own user
(``AUTOGRADER_STUDENT_USER``), the grader checks as that user that nothing private is
readable (:func:`autograder.isolation.environment.require_safe_environment`), and in every
setup it starts one student process that closes its sandbox and loads nothing
(:func:`autograder.isolation.process.probe_sandbox`: capabilities, Landlock, seccomp); if
either fails, it writes a results file that says so and stops without grading. Where nothing
confines the file system of a submission running as the grader's own user, it says so in
one line. The results file is the grader's alone (no student process can write anywhere); a
write that fails is one line on stderr and exit status 3, not a traceback.

Markers
-------
``@pytest.mark.points(n)``                 the test's max score (default 1)
``@pytest.mark.visibility("visible" | "after_due_date" | "hidden")``  Gradescope visibility

Partial credit: a test takes the ``grade`` fixture and calls ``grade.set(score, output)``
(score in points, at most the marker's ``n``); a test that passes without setting a score
gets full points, a failing one its score so far (0 by default).
"""
from __future__ import annotations

import os
import sys

import pytest

from .results import Results, ResultsError

_RESULTS = pytest.StashKey[Results]()


def pytest_addoption(parser):
    """Add the grader's options (``--impl``, ``--gradescope``, ...) to pytest."""
    group = parser.getgroup("autograder")
    group.addoption("--impl", default=None, metavar="PATH_OR_MODULE",
                    help="implementation to grade: module name, .py file or package folder "
                         "(default: autograder.solution, the reference solution)")
    group.addoption("--assignment", default="path-tracing", metavar="NAME",
                    help="the assignment whose checks are graded (default: path-tracing)")
    group.addoption("--gradescope", default=None, metavar="RESULTS_JSON",
                    help="write Gradescope results.json here, atomically after every test")
    group.addoption("--grading-pictures", default=None, metavar="DIR",
                    help="folder for the z-map pictures of failed checks")
    group.addoption("--solution-runtime", action="store_true", default=False,
                    help="instructors only: the implementation may build on the reference "
                         "solution (bug-zoo mutants, correct alternatives)")


def pytest_configure(config):
    """Register the grader's markers and, with ``--gradescope``, the results file."""
    config.addinivalue_line("markers", "points(n): max score of a graded test")
    config.addinivalue_line("markers", "visibility(v): Gradescope visibility: visible, "
                                       "after_due_date, after_published or hidden")
    from .grading import ASSIGNMENTS
    assignment = config.getoption("--assignment")
    if assignment not in ASSIGNMENTS:
        raise pytest.UsageError(f"--assignment {assignment}: unknown; the assignments are "
                                f"{', '.join(ASSIGNMENTS)}")
    path = config.getoption("--gradescope")
    if path:
        config.stash[_RESULTS] = Results(path)


def pytest_sessionstart(session):
    """Refuse to grade in an environment where the submission could read private files or
    where the student process cannot close its sandbox."""
    from .isolation.environment import SetupError, require_safe_environment
    from .isolation.process import probe_sandbox
    results = session.config.stash.get(_RESULTS, None)
    extra = [os.path.dirname(results.path)] if results is not None else []
    try:
        require_safe_environment(extra=extra)
        probe_sandbox()
    except SetupError as error:
        message = f"The autograder is not set up safely; please contact the course staff. ({error})"
        if results is not None:
            results.output = message
            _write(session.config, results)
        pytest.exit(message, returncode=3)


_WRITE_FAILED = pytest.StashKey[str]()


def _write(config, results: Results, record=None) -> None:
    """``results.write()`` (or ``record``); a failure is one line on stderr, remembered for
    the exit status, never a traceback."""
    try:
        (record or results.write)()
    except ResultsError as error:
        if config.stash.get(_WRITE_FAILED, None) != str(error):
            print(str(error), file=sys.stderr)
        config.stash[_WRITE_FAILED] = str(error)


class Grade:
    """Per-test score holder (the ``grade`` fixture)."""

    def __init__(self, max_score: float):
        self.max_score = float(max_score)
        self.score = None
        self.output = ""

    def set(self, score: float, output: str = "") -> None:
        self.score = max(0.0, min(float(score), self.max_score))
        self.output = output


def points_of(item) -> float:
    """Points a graded test is worth (its ``points`` marker)."""
    marker = item.get_closest_marker("points")
    return float(marker.args[0]) if marker and marker.args else 1.0


def visibility_of(item) -> str:
    """When Gradescope shows a test to the student (its ``visibility`` marker)."""
    marker = item.get_closest_marker("visibility")
    return str(marker.args[0]) if marker and marker.args else "visible"


def test_name(item) -> str:
    """The title of a graded test in Gradescope's results."""
    doc = getattr(item, "function", None) and item.function.__doc__
    title = doc.strip().splitlines()[0] if doc else item.name
    if "[" in item.name:
        title = f"{title} [{item.name.split('[', 1)[1]}"
    return title


@pytest.fixture
def grade(request) -> Grade:
    """Record a partial score: ``grade.set(points, output)``."""
    holder = Grade(points_of(request.node))
    request.node._autograder_grade = holder
    return holder


@pytest.fixture(scope="session")
def implementation(request) -> str:
    """The ``--impl`` to grade (absolute path or module name)."""
    from .contract import DEFAULT_IMPLEMENTATION
    impl = request.config.getoption("--impl") or DEFAULT_IMPLEMENTATION
    return os.path.abspath(impl) if os.path.exists(impl) else impl


@pytest.fixture(scope="session")
def trusted_implementation(request) -> bool:
    """Whether ``--solution-runtime`` was given."""
    return bool(request.config.getoption("--solution-runtime"))


@pytest.fixture(scope="session")
def pictures_dir(request, tmp_path_factory):
    """Folder for the diagnostic pictures of the graded checks."""
    folder = request.config.getoption("--grading-pictures")
    results = request.config.getoption("--gradescope")
    if folder:
        return folder
    if results:
        return os.path.join(os.path.dirname(os.path.abspath(results)), "pictures")
    return str(tmp_path_factory.mktemp("pictures"))


def pytest_collection_finish(session):
    """Enter every selected test (after ``-k`` / ``-m`` deselection) as "not run"."""
    results = session.config.stash.get(_RESULTS, None)
    if results is None:
        return
    for item in session.items:
        results.add_pending(item.nodeid, test_name(item), points_of(item), visibility_of(item))
    _write(session.config, results)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Record each graded test's score and output in the results file."""
    outcome = yield
    report = outcome.get_result()
    results = item.config.stash.get(_RESULTS, None)
    if results is None:
        return
    failed_now = report.failed
    done = (report.when == "call") or (report.when == "setup" and (report.failed or report.skipped))
    if not done:
        return
    holder = getattr(item, "_autograder_grade", None)
    max_score = points_of(item)
    passed = report.passed and not failed_now
    if holder is not None and holder.score is not None:
        score = holder.score if not passed else (holder.score if holder.score < max_score else max_score)
    else:
        score = max_score if passed else 0.0
    output = holder.output if holder is not None and holder.output else ""
    if report.failed and not output:
        output = _failure_text(report)
    elif report.skipped:
        output = f"skipped: {report.longrepr[2] if isinstance(report.longrepr, tuple) else report.longrepr}"
    _write(item.config, results, lambda: results.record(
        item.nodeid, test_name(item), score, max_score, passed and score >= max_score, output,
        visibility_of(item)))


def _failure_text(report) -> str:
    crash = getattr(report.longrepr, "reprcrash", None)
    if crash is not None:
        return crash.message
    return str(report.longrepr)[-3000:]


def pytest_sessionfinish(session, exitstatus):
    """Write Gradescope's results file once every test has run."""
    results = session.config.stash.get(_RESULTS, None)
    if results is None:
        return
    failed = session.config.stash.get(_WRITE_FAILED, None)
    session.config.stash[_WRITE_FAILED] = ""          # the last write decides
    if exitstatus == pytest.ExitCode.INTERRUPTED:
        results.interrupted()                         # an interrupt is not a verdict
    _write(session.config, results)
    if session.config.stash[_WRITE_FAILED] or (failed and not os.path.exists(results.path)):
        session.exitstatus = 3
