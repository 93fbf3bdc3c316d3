"""One place decides whether a test that needs a live Mitsuba 3 runs or skips.

A test needs Mitsuba when it carries ``@pytest.mark.mitsuba`` or takes the ``mi`` fixture
(which marks it). Without an importable Mitsuba such tests skip with the import error as
the reason, so the README's ``pytest -q`` passes on a machine without Mitsuba (the built-in
scenes' references are committed). ``PATHTRACER_REQUIRE_MITSUBA=1`` turns those skips into
failures: CI's second pass (``pytest -m mitsuba``) sets it, so a broken install cannot
pass by skipping everything.

Tests marked ``@pytest.mark.cycles`` need Blender's ``bpy`` (examples/cycles) and skip the same
way without it; ``PATHTRACER_REQUIRE_CYCLES=1`` turns those skips into failures.
"""
from __future__ import annotations

import functools
import os
import shutil
import subprocess
import sys
import tempfile

import pytest


@functools.cache
def _mitsuba_import_error() -> str | None:
    """Why Mitsuba cannot be used here, or None when it can."""
    try:
        import mitsuba
        mitsuba.set_variant("scalar_rgb")
    except (ImportError, AttributeError) as error:  # absent, broken, or without scalar_rgb
        return f"{type(error).__name__}: {error}"
    return None


@functools.cache
def _bpy_import_error() -> str | None:
    """Why Blender's ``bpy`` cannot be imported here, or None when it can.

    Tried in a child process: importing ``bpy`` loads all of Blender into the process, which
    only the renders (each a process of its own) need.
    """
    try:
        result = subprocess.run([sys.executable, "-c", "import bpy"], capture_output=True,
                                text=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired) as error:
        return f"{type(error).__name__}: {error}"
    if result.returncode == 0:
        return None
    lines = result.stderr.strip().splitlines()
    return lines[-1] if lines else f"import bpy exited with {result.returncode}"


def pytest_configure(config):
    """Point the user reference cache (``MITSUBA_REFS_CACHE``) at a folder of this session's:
    references the tests render never land in the package (``mitsuba_refs/references``, the
    committed ones, which lookups still read first) nor in the user's own cache."""
    folder = tempfile.mkdtemp(prefix="mitsuba-refs-cache-")
    config._refs_cache = folder
    os.environ["MITSUBA_REFS_CACHE"] = folder


def pytest_unconfigure(config):
    folder = getattr(config, "_refs_cache", None)
    if folder:
        shutil.rmtree(folder, ignore_errors=True)


def pytest_collection_modifyitems(config, items):
    # Taking `mi` is needing Mitsuba: mark it, so `pytest -m mitsuba` selects the test.
    for item in items:
        if "mi" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.mitsuba)


def pytest_runtest_setup(item):
    if item.get_closest_marker("cycles") is not None:
        error = _bpy_import_error()
        if error is not None:
            message = f"needs Blender's bpy for Cycles, pip install bpy==5.0.1 ({error})"
            if os.environ.get("PATHTRACER_REQUIRE_CYCLES") == "1":
                pytest.fail(f"{message}; PATHTRACER_REQUIRE_CYCLES=1 forbids skipping", pytrace=False)
            pytest.skip(message)
    if item.get_closest_marker("mitsuba") is None:
        return
    error = _mitsuba_import_error()
    if error is None:
        return
    message = f"needs a live Mitsuba 3 ({error})"
    if os.environ.get("PATHTRACER_REQUIRE_MITSUBA") == "1":
        pytest.fail(f"{message}; PATHTRACER_REQUIRE_MITSUBA=1 forbids skipping", pytrace=False)
    pytest.skip(message)


#: Module fixtures that hold Mitsuba in another variant for their module (and restore it).
VARIANT_FIXTURES = {"mi_llvm", "mi_variant"}


@pytest.fixture(autouse=True)
def _scalar_variant_after(request):
    """Leave Mitsuba in ``scalar_rgb`` after every test.

    Rendering a reference switches the process to a JIT variant when one works; a test
    that did so must not leave the next test of the same worker in it (``mi`` is set up
    once per session).
    """
    yield
    mitsuba = sys.modules.get("mitsuba")
    if mitsuba is None or VARIANT_FIXTURES & set(request.fixturenames):
        return
    if mitsuba.variant() not in (None, "scalar_rgb"):
        mitsuba.set_variant("scalar_rgb")


@pytest.fixture(scope="session")
def mi():
    """The ``mitsuba`` module in its ``scalar_rgb`` variant (the test is skipped without it).

    Tests that need another variant set it themselves and restore ``scalar_rgb``.
    """
    import mitsuba
    mitsuba.set_variant("scalar_rgb")
    return mitsuba
