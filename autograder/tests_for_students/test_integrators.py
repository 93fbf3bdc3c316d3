"""The graded tests: one per check of the assignment graded (:data:`autograder.grading.ASSIGNMENTS`).

Run with ``pytest autograder/tests_for_students [--assignment NAME] --impl PATH
--gradescope results.json``: the plugin is a pytest11 entry point of the installed project
(from a source tree that is not pip-installed, add ``-p autograder.plugin``). Points and
visibility come from the markers; each test scores its parts (mean / variance /
convergence) for partial credit.
"""
import pytest

from autograder.grading import checks_of, run_check

_HISTORY = {}


def _params(assignment):
    for check in checks_of(assignment):
        visibility = "visible"
        if check.glass:
            visibility = "after_due_date"       # the glass checks are revealed after the deadline
        yield pytest.param(check, id=check.id, marks=[pytest.mark.points(check.points),
                                                      pytest.mark.visibility(visibility)])


def pytest_generate_tests(metafunc):
    """One test per check of the assignment that ``--assignment`` names."""
    if "check" in metafunc.fixturenames:
        metafunc.parametrize("check", list(_params(metafunc.config.getoption("--assignment"))))


def test_check(check, implementation, trusted_implementation, pictures_dir, grade):
    """Agreement with Mitsuba 3."""
    result = run_check(check, implementation, out_dir=pictures_dir, history=_HISTORY,
                       trusted=trusted_implementation)
    _HISTORY[check.id] = result
    grade.set(result.score, result.report())
    assert result.passed, result.report()
