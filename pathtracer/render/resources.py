"""Up-front resource checks: whether a render fits in memory and its numbers can be stored.

A render that cannot finish should be refused before it starts, with what it needs, rather
than die in an allocation (or crash writing its file) after the work is done.
"""
from __future__ import annotations

import os

#: Running per-pixel statistics: the count (one float64) and mean and M2 (3 float64 each);
#: the returned mean and variance images are views of them (docs/performance.md).
STATS_BYTES_PER_PIXEL = 56
#: Writing the outputs: float32 EXR channels (24 bytes) and the PNG tonemap's float64
#: temporaries (about 4 images of 24 bytes) plus its 8-bit image.
OUTPUT_BYTES_PER_PIXEL = 24 + 4 * 24 + 3
#: Memory of one camera path in flight (rays, hits, throughput, random state), measured
#: as about 1 KB (docs/performance.md): a batch of 32k paths holds ~32 MB.
BYTES_PER_PATH = 1024
#: Batches (units) handed at once to an integrator that refills a pool of paths
#: (``pathtracer.render`` uses it): its worker holds their camera samples together.
POOL_UNITS = 4
#: Memory per camera sample of the units a process has in hand (camera ray, random key,
#: result row; ~200 bytes): 0.8 KB per path of the batch with four units.
BYTES_PER_UNIT_SAMPLE = POOL_UNITS * 200
#: The largest spp an EXR header (a signed 32-bit int) can record.
SPP_MAX = 2 ** 31 - 1


def render_memory(n_pixels: int, processes: int, batch_size: int) -> int:
    """Bytes a render and the writing of its outputs need at the peak (an estimate).

    Parameters
    ----------
    n_pixels : int
        Width x height of the film.
    processes : int
        Worker processes; each holds one batch of ``batch_size`` paths.
    batch_size : int
        Camera paths per batch.
    """
    per_pixel = STATS_BYTES_PER_PIXEL + OUTPUT_BYTES_PER_PIXEL
    return n_pixels * per_pixel + max(1, processes) * batch_size * (BYTES_PER_PATH
                                                                  + BYTES_PER_UNIT_SAMPLE)


def available_memory() -> int | None:
    """Bytes this process can still allocate: MemAvailable, lowered by a cgroup limit.

    Returns None where neither can be read (not Linux).
    """
    limits = [value for value in (_meminfo_available(), _cgroup_headroom()) if value is not None]
    return min(limits) if limits else None


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def _cgroup_headroom() -> int | None:
    """memory.max - memory.current of this process's cgroup (v2), if it has a limit."""
    try:
        with open("/proc/self/cgroup") as f:
            path = next(line.split(":", 2)[2].strip() for line in f if line.startswith("0::"))
        base = os.path.join("/sys/fs/cgroup", path.lstrip("/"))
        with open(os.path.join(base, "memory.max")) as f:
            limit = f.read().strip()
        if limit == "max":
            return None
        with open(os.path.join(base, "memory.current")) as f:
            return max(0, int(limit) - int(f.read().strip()))
    except (OSError, ValueError, StopIteration, IndexError):
        return None


def format_bytes(count: float) -> str:
    """``1234567`` -> ``'1.2 MB'`` (decimal units)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(count) < 1000 or unit == "TB":
            return f"{count:.0f} {unit}" if unit == "B" else f"{count:.1f} {unit}"
        count /= 1000
    raise AssertionError("unreachable")


def check_memory(width: int, height: int, processes: int, batch_size: int,
                 available: int | None = None) -> None:
    """Raise ValueError when a ``width`` x ``height`` render would not fit in memory.

    ``available`` defaults to :func:`available_memory`; when that is unknown nothing is
    refused.
    """
    need = render_memory(width * height, processes, batch_size)
    available = available_memory() if available is None else available
    if available is not None and need > available:
        raise ValueError(
            f"a {width}x{height} image needs about {format_bytes(need)} of memory "
            f"({STATS_BYTES_PER_PIXEL + OUTPUT_BYTES_PER_PIXEL} bytes per pixel for its "
            f"statistics and outputs, "
            f"{format_bytes(batch_size * (BYTES_PER_PATH + BYTES_PER_UNIT_SAMPLE))} per process), "
            f"but only {format_bytes(available)} is available; render fewer pixels "
            "(--resolution WxH, or -D width=... -D height=...) or use fewer --processes")


def check_spp(spp: int) -> None:
    """Raise ValueError unless ``1 <= spp <= SPP_MAX`` (what the EXR header can record)."""
    if not 1 <= spp <= SPP_MAX:
        raise ValueError(f"spp must lie in [1, {SPP_MAX}], got {spp}")
