"""Tests that compare with a live Mitsuba 3 skip, saying why, when it cannot be imported.

Mitsuba is optional at test time (the references are committed); CI installs it, so there
these tests run.
"""
import pytest


def import_mitsuba_or_skip():
    """The mitsuba module, or skip the calling test with the import error as the reason."""
    try:
        import mitsuba as mi
    except ImportError as error:  # absent, or a broken install
        pytest.skip(f"mitsuba is not importable ({error}): no comparison with Mitsuba 3")
    return mi
