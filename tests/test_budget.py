"""The suite's error budget holds: at most 0.1 % chance of failing a correct tracer.

Counts the statistical assertions of the collected suite (tests marked
``statistical``, weighted by their ``assertions``), each at ``ALPHA``, and
checks Bonferroni's bound. Adding statistical tests beyond the budget fails
here instead of silently raising the false-failure rate.
"""
import subprocess
import sys
from pathlib import Path

from tests.budget import ALPHA, MAX_STATISTICAL_TESTS, SUITE_ALPHA

ROOT = Path(__file__).resolve().parent.parent
COUNTER = """
import pytest, sys
class Count:
    total = 0
    def pytest_collection_finish(self, session):
        for item in session.items:
            mark = item.get_closest_marker("statistical")
            if mark is not None:
                Count.total += mark.kwargs.get("assertions", 1)
pytest.main(["--collect-only", "-q", "-p", "no:cacheprovider", "tests"], plugins=[Count()])
sys.stderr.write(f"STATISTICAL={Count.total}\\n")
"""


def test_statistical_assertions_fit_the_budget():
    out = subprocess.run([sys.executable, "-c", COUNTER], cwd=ROOT, capture_output=True, text=True,
                         timeout=300)
    line = [l for l in out.stderr.splitlines() if l.startswith("STATISTICAL=")]
    assert line, out.stderr[-2000:]
    assertions = int(line[-1].split("=")[1])
    assert assertions > 100          # the suites were found
    assert assertions <= MAX_STATISTICAL_TESTS
    # SUITE_ALPHA / MAX * MAX may round one ulp above SUITE_ALPHA (it does for MAX = 519).
    assert assertions * ALPHA <= SUITE_ALPHA * (1 + 1e-12)
