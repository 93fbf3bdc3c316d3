"""pytest plugin: the ``mitsuba_refs`` fixture, with the suite's false-failure budget.

Installed with the package (entry point ``pytest11``), so a renderer's own repository only
writes tests::

    @pytest.mark.mitsuba_refs(checks=2)          # optional: this test checks twice
    def test_my_renderer(mitsuba_refs):
        mitsuba_refs.assert_agrees("cornell-box", command="./render ... {spp} {seed} {out}")
        mitsuba_refs.assert_agrees("smallpt", command="./render ... {spp} {seed} {out}")

``--mitsuba-refs-budget P`` (default 1e-3) is the probability that a correct renderer fails
any of the suite's checks; the plugin counts the checks of the collected tests that take the
fixture, runs every verdict at ``P / (3 x checks)`` (:class:`mitsuba_refs.testing.SuiteBudget`)
and says so in the report header. Loading the plugin imports the ``mitsuba_refs`` package (and
with it NumPy and the tracer); the statistics and SciPy load only when a test takes the fixture.
"""
from __future__ import annotations

import pytest

#: The suite's default budget (mitsuba_refs.stats.budget.SUITE_ALPHA, kept here as a number:
#: the statistics package imports SciPy, which a session without the fixture does not need).
DEFAULT_BUDGET = 1e-3
FIXTURE = "mitsuba_refs"


def pytest_addoption(parser):
    """The ``--mitsuba-refs-budget`` option."""
    group = parser.getgroup("mitsuba-refs")
    group.addoption("--mitsuba-refs-budget", type=float, default=DEFAULT_BUDGET, metavar="P",
                    help="probability that a correct renderer fails any check of the suite "
                         f"(default {DEFAULT_BUDGET:g}); split over the checks")


def pytest_configure(config):
    """Declare the marker; no checks counted yet."""
    config.addinivalue_line("markers", "mitsuba_refs(checks=1): a test taking the mitsuba_refs "
                                       "fixture that runs this many checks (the budget's share)")
    config._mitsuba_refs_checks = 0


def pytest_collection_modifyitems(session, config, items):
    """Count the checks of the collected tests that take the fixture."""
    config._mitsuba_refs_checks = sum(_checks(item) for item in items
                                      if FIXTURE in getattr(item, "fixturenames", ()))


def _checks(item) -> int:
    marker = item.get_closest_marker("mitsuba_refs")
    checks = int(marker.kwargs.get("checks", 1)) if marker else 1
    if checks < 1:
        raise pytest.UsageError(f"{item.nodeid}: mitsuba_refs(checks={checks}) must be >= 1")
    return checks


def pytest_report_header(config):
    """The budget line in the report's header."""
    checks = getattr(config, "_mitsuba_refs_checks", 0)
    if checks:
        return _budget(config).describe()
    return None


def pytest_collection_finish(session):
    """The budget line once the checks are counted (after the header)."""
    checks = session.config._mitsuba_refs_checks
    if checks:
        reporter = session.config.pluginmanager.get_plugin("terminalreporter")
        if reporter is not None:
            reporter.write_line(_budget(session.config).describe())


def _budget(config):
    # The harness (NumPy, SciPy, the tracer) loads only once a test takes the fixture.
    from .testing import SuiteBudget
    budget = config.getoption("--mitsuba-refs-budget")
    if not 0 < budget < 1:
        raise pytest.UsageError(f"--mitsuba-refs-budget must be between 0 and 1, got {budget}")
    return SuiteBudget(budget, max(1, config._mitsuba_refs_checks))


class Checker:
    """What the fixture gives: :func:`mitsuba_refs.testing.assert_agrees` at the suite's level."""

    def __init__(self, budget, out_dir):
        self.budget, self.out_dir = budget, out_dir

    @property
    def alpha(self) -> float:
        """Level of each verdict."""
        return self.budget.alpha

    def assert_agrees(self, scene, **options):
        """As :func:`mitsuba_refs.testing.assert_agrees`, pictures in the test's folder (unless
        ``out_dir`` or ``settings.out_dir`` says where)."""
        from .testing import assert_agrees
        settings = options.get("settings")
        if settings is None or settings.out_dir is None:
            options.setdefault("out_dir", self.out_dir)
        return assert_agrees(scene, budget=self.budget, **options)


@pytest.fixture
def mitsuba_refs(request, tmp_path):
    """A :class:`Checker` whose verdicts share the suite's false-failure budget."""
    return Checker(_budget(request.config), tmp_path / "mitsuba-refs")
