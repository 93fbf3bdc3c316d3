r"""The suite-wide error budget: how much false-failure probability each test may spend.

A correct tracer must fail the whole suite with probability at most ``suite_alpha``
(default 0.1 %).  With :math:`m` registered tests, each at level :math:`\alpha_1`,

* Šidák (independent tests): :math:`P(\text{any false failure}) = 1-(1-\alpha_1)^m`, so
  :math:`\alpha_1 = 1-(1-\alpha_{suite})^{1/m}`;
* Bonferroni (any dependence): :math:`P \le m\alpha_1`, so :math:`\alpha_1=\alpha_{suite}/m`.

The two differ by < 0.05 % relative at these levels; Šidák is exact for independent tests
and Bonferroni never exceeds the budget whatever the dependence (e.g. tests sharing a
reference image).  The default is Bonferroni (safe).  Without a budget, ~50 tests at 0.01
each fail a correct tracer ~40 % of the time (1-0.99^50 = 0.395).

Tests that combine several components (the mean test's tiles + image, the convergence
slope + floor) split their own alpha internally; they count once here.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = ["SUITE_ALPHA", "per_test_alpha", "suite_false_failure", "ErrorBudget"]

SUITE_ALPHA = 1e-3


def per_test_alpha(n_tests: int, suite_alpha: float = SUITE_ALPHA, *, method: str = "bonferroni") -> float:
    """Per-test level so that ``n_tests`` tests falsely fail a correct tracer with prob. <= suite_alpha.

    >>> round(per_test_alpha(50), 8)
    2e-05
    """
    if n_tests < 1:
        raise ValueError("n_tests must be >= 1")
    if not (0 < suite_alpha < 1):
        raise ValueError("suite_alpha must be in (0, 1)")
    if method == "bonferroni":
        return suite_alpha / n_tests
    if method == "sidak":
        return -math.expm1(math.log1p(-suite_alpha) / n_tests)
    raise ValueError("method must be 'bonferroni' or 'sidak'")


def suite_false_failure(per_test: float, n_tests: int) -> float:
    """Chance that at least one of ``n_tests`` independent tests at ``per_test`` falsely fails."""
    return -math.expm1(n_tests * math.log1p(-per_test))


@dataclass
class ErrorBudget:
    """A registry of tests sharing one suite-wide budget (weighted Bonferroni).

    Register every statistical test once (at import / collection time) with a weight
    (default 1); :meth:`alpha` gives its level ``suite_alpha * weight / total_weight``.
    Weights let a cheap, important test spend more of the budget.

    >>> b = ErrorBudget(1e-3); b.register("cornell/mean"); b.register("cornell/variance")
    >>> b.alpha("cornell/mean")
    0.0005
    """

    suite_alpha: float = SUITE_ALPHA
    weights: dict = field(default_factory=dict)

    def register(self, name: str, weight: float = 1.0) -> None:
        if weight <= 0:
            raise ValueError("weight must be > 0")
        self.weights[name] = float(weight)

    @property
    def n_tests(self) -> int:
        return len(self.weights)

    def alpha(self, name: str) -> float:
        total = sum(self.weights.values())
        return self.suite_alpha * self.weights[name] / total

    def worst_case_suite_alpha(self) -> float:
        """Bonferroni bound on the suite's false-failure probability (= suite_alpha)."""
        return sum(self.alpha(k) for k in self.weights)
