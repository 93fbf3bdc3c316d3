"""The suite's error budget: one place that fixes each statistical test's alpha.

A correct tracer must fail the whole suite with probability at most 0.1 %.
Every statistical assertion in the suite uses ``ALPHA``; with at most
``MAX_STATISTICAL_TESTS`` of them, Bonferroni's inequality bounds the chance
of any false failure by MAX_STATISTICAL_TESTS * ALPHA = 1e-3.
``tests/test_budget.py`` counts the registered statistical tests and fails if
the suite outgrows the budget.
"""
SUITE_ALPHA = 1e-3
MAX_STATISTICAL_TESTS = 608
ALPHA = SUITE_ALPHA / MAX_STATISTICAL_TESTS
