"""The allocator setting that keeps freed array memory in the heap (pathtracer.render.allocator)."""
import sys

import pytest

from pathtracer.render.allocator import keep_freed_memory


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_keep_freed_memory_applies_once_per_process():
    assert keep_freed_memory() is True
    assert keep_freed_memory() is True   # idempotent: later renders call it again
