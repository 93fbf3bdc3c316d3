"""The graded tests that Gradescope runs on a submission (see test_integrators.py)."""
