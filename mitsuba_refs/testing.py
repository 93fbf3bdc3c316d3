"""Mitsuba's verdicts inside a renderer's own test suite.

::

    from mitsuba_refs.testing import assert_agrees

    def test_cornell_box():
        assert_agrees("cornell-box", command="./build/render {scene} --spp {spp} --seed {seed} "
                                             "--size {width}x{height} -o {out}")

:func:`assert_agrees` runs :func:`mitsuba_refs.external.check.check` and raises
:class:`Disagreement` (an ``AssertionError``) with the verdict lines, the likely causes and
the picture paths when a verdict fails. A bad command or image is a
:class:`~mitsuba_refs.errors.RefsInputError`, not a failure.

**The suite's false-failure budget.** A correct renderer must fail the whole suite with
probability at most ``budget`` (default 1e-3). Each check makes up to three verdicts (mean,
variance, convergence), so with ``n`` checks sharing the budget each verdict runs at
``alpha = budget / (3 n)`` (Bonferroni: the bound holds whatever the dependence between
checks). Outside pytest, give ``alpha`` or a :class:`SuiteBudget`. Under pytest the plugin
(:mod:`mitsuba_refs.pytest_plugin`) counts the tests that take the ``mitsuba_refs`` fixture
(``@pytest.mark.mitsuba_refs(checks=k)`` for a test that checks ``k`` times), sets the level,
and prints the budget and how many checks share it.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

from .external.check import check
from .settings import Settings
from .stats.budget import SUITE_ALPHA, per_test_alpha
from .verdicts.compare import write_pictures

#: Where a failing :func:`assert_agrees` draws its pictures when no ``out_dir`` is given
#: (as ``mitsuba-refs check`` does in ``out/check``), relative to the working folder.
FAILURE_PICTURES = Path("out") / "assert_agrees"

#: Verdicts one check makes at most (mean, variance, convergence): each spends its alpha.
VERDICTS_PER_CHECK = 3


class Disagreement(AssertionError):
    """A verdict failed: the message is the check's report (verdicts, causes, pictures)."""

    def __init__(self, result):
        super().__init__("\n" + result.report())
        self.result = result


class Inconclusive(AssertionError):
    """With a tolerance, the budget ran out before the mean was decided (the report says how
    many samples would decide)."""

    def __init__(self, result):
        super().__init__("\n" + result.report())
        self.result = result


@dataclass
class SuiteBudget:
    """The false-failure budget of a suite of ``checks`` checks.

    Attributes
    ----------
    budget : float
        Probability that a correct renderer fails any check of the suite, at most.
    checks : int
        Checks sharing it.
    """

    budget: float = SUITE_ALPHA
    checks: int = 1

    @property
    def alpha(self) -> float:
        """Level of each verdict."""
        return per_test_alpha(VERDICTS_PER_CHECK * max(1, self.checks), self.budget)

    def describe(self) -> str:
        """One line for the test report."""
        return (f"mitsuba-refs: suite false-failure budget {self.budget:g} shared by {self.checks} "
                f"check(s), {VERDICTS_PER_CHECK} verdicts each: every verdict at alpha = "
                f"{self.alpha:.3g}")


def assert_agrees(scene, *, command=None, images=None, settings: Settings | None = None,
                  alpha=None, budget=None, tolerance=None, **options):
    """Check a renderer (``command``) or its ``images`` against Mitsuba on ``scene``; raise
    :class:`Disagreement` unless every verdict agrees.

    Parameters
    ----------
    scene : str or Path
        Built-in scene name or Mitsuba XML file.
    command, images
        As for ``mitsuba-refs check --command / --images``.
    settings : mitsuba_refs.settings.Settings, optional
        What is rendered and how it is judged (:func:`mitsuba_refs.external.check.check`);
        its ``alpha`` is replaced by the level below.
    alpha : float, optional
        Level of each verdict; default from ``budget``.
    budget : SuiteBudget, optional
        The suite's budget (default: one check with the default budget).
    tolerance : float, optional
        Percent: the mean must be shown within +-``tolerance`` % (``--tolerance``), rendered in
        rounds up to ``max_spp`` (a Settings field, default ``spp``); :class:`Inconclusive` when
        the budget runs out first. The suite's budget bounds false DISAGREES (and false
        AGREES at the tolerance); an INCONCLUSIVE check asks for a larger ``max_spp``.
    **options
        Keyword arguments of :func:`mitsuba_refs.external.check.check`: ``params``,
        ``renderer_scene``, ... and the fields of ``Settings`` (``same_estimator``,
        ``reference``, ``out_dir``, ``jobs``, ``detect`` (a :class:`mitsuba_refs.settings.Detect`:
        the spp that sees a target bias), ...), which replace those of ``settings``. The
        result's ``detectable`` says what its mean test could see.

    Returns
    -------
    Comparison
        The verdicts, when they all agree.
    """
    level = alpha if alpha is not None else (budget or SuiteBudget()).alpha
    if tolerance is not None:
        options["tolerance"] = tolerance
    result = check(scene, command=command, images=images, settings=settings, alpha=level,
                   **options)
    if getattr(result, "outcome", None) == "INCONCLUSIVE":
        raise Inconclusive(result)
    if not result.agree:
        raise Disagreement(with_pictures(result, FAILURE_PICTURES))
    return result


def with_pictures(result, out_dir):
    """``result`` with its diagnostic pictures, drawn into ``out_dir`` when the check drew none
    (no ``out_dir`` was given): a failure always says where to look."""
    arrays = result.arrays
    if result.pictures or "test_mean" not in arrays:
        return result
    reference = SimpleNamespace(mean=arrays["reference_mean"], var=arrays["reference_variance"])
    pictures = write_pictures(result, Path(out_dir), arrays["test_mean"], arrays["test_variance"],
                              reference)
    return dataclasses.replace(result, pictures=pictures)
