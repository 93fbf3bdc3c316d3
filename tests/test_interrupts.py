"""A Ctrl-C inside a file reader is an interrupt, never a verdict on the file.

OpenEXR's reader turns a ``KeyboardInterrupt`` that lands during a read into an error of
its own ("initialization failed"); the readers used to report the file as corrupt (a
reference would then be rebuilt). Here the interrupt is delivered at a known point, inside
a reader that swallows it as OpenEXR does, so the tests do not depend on timing.
"""
from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from mitsuba_refs.reference import cache
from mitsuba_refs.reference.cache_location import committed_dir
from pathtracer.core import interrupts
from pathtracer.io import bitmap
from tests.interrupting import swallowing_reader

REPO = Path(__file__).resolve().parent.parent


@pytest.fixture
def remembering():
    """SIGINT handled by :func:`interrupts.remember` for the test, then as before."""
    previous = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    assert interrupts.install()
    yield
    signal.signal(signal.SIGINT, previous)


def test_the_handler_counts_and_raises(remembering):
    before = interrupts.count()
    with pytest.raises(KeyboardInterrupt):
        signal.raise_signal(signal.SIGINT)
    assert interrupts.count() == before + 1


def test_install_keeps_a_handler_of_someone_else():
    previous = signal.getsignal(signal.SIGINT)
    def own(signum, frame):
        raise KeyboardInterrupt
    signal.signal(signal.SIGINT, own)
    try:
        assert not interrupts.install() and signal.getsignal(signal.SIGINT) is own
    finally:
        signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize("interrupt", [True, False])
def test_reference_read_interrupted_is_an_interrupt(remembering, monkeypatch, interrupt):
    monkeypatch.setattr(cache, "read_mean_variance", swallowing_reader(interrupt))
    args = ("quad-light", {"width": 64, "height": 48}, "path", 4096, 1, committed_dir())
    if interrupt:
        with pytest.raises(KeyboardInterrupt):
            cache.validate(*args)
    else:                                   # the same error without an interrupt: a bad file
        status, detail, _ = cache.validate(*args)
        assert status == "corrupt" and "initialization failed" in detail


@pytest.mark.parametrize("interrupt", [True, False])
def test_bitmap_read_interrupted_is_an_interrupt(remembering, monkeypatch, tmp_path, interrupt):
    image = tmp_path / "sky.exr"
    image.write_bytes(b"not read")
    monkeypatch.setattr(bitmap, "read_channels", swallowing_reader(interrupt))
    if interrupt:
        with pytest.raises(KeyboardInterrupt):
            bitmap.read_bitmap(image)
    else:
        with pytest.raises(bitmap.BitmapError, match="not a readable OpenEXR file"):
            bitmap.read_bitmap(image)


def test_ctrl_c_while_compare_reads_a_reference_is_exit_130(tmp_path):
    # The interrupt of tests/test_refs_cli_faults.py's timing test, delivered exactly where it
    # once made `compare` call a committed reference corrupt (exit 2).
    script = f"""
import signal, sys
sys.path.insert(0, {str(REPO)!r})
from mitsuba_refs.reference import cache
real = cache.read_mean_variance
def interrupted(path):
    try:
        signal.raise_signal(signal.SIGINT)
    except KeyboardInterrupt:
        raise RuntimeError("initialization failed") from None
    return real(path)
cache.read_mean_variance = interrupted
from mitsuba_refs.cli.main import main
sys.exit(main(["compare", "quad-light", "--processes", "1", "--out", {str(tmp_path / "out")!r}]))
"""
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300,
                          env={"PATH": "/usr/bin:/bin", "MITSUBA_REFS_CACHE": str(REPO / "mitsuba_refs" / "references"),
                               "MITSUBA_REFS_VARIANT": "scalar_rgb"})
    assert done.returncode == 130, done.stderr
    assert done.stderr.strip() == "mitsuba-refs: interrupted"
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
