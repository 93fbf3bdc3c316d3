"""The graded tests: one per check of :data:`autograder.grading.CHECKS`.

Run with ``pytest autograder/tests_for_students --impl PATH
--gradescope results.json``: the plugin is a pytest11 entry point of the installed project
(from a source tree that is not pip-installed, add ``-p autograder.plugin``). Points and
visibility come from the markers; each test scores its parts (mean / variance /
convergence) for partial credit.
"""
import pytest

from autograder.grading import CHECKS, run_check

_HISTORY = {}


def _params():
    for check in CHECKS:
        visibility = "visible"
        if check.glass:
            visibility = "after_due_date"       # the glass checks are revealed after the deadline
        yield pytest.param(check, id=check.id, marks=[pytest.mark.points(check.points),
                                                      pytest.mark.visibility(visibility)])


@pytest.mark.parametrize("check", list(_params()))
def test_check(check, implementation, trusted_implementation, pictures_dir, grade):
    """Agreement with Mitsuba 3."""
    result = run_check(check, implementation, out_dir=pictures_dir, history=_HISTORY,
                       trusted=trusted_implementation)
    _HISTORY[check.id] = result
    grade.set(result.score, result.report())
    assert result.passed, result.report()
