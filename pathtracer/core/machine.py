"""What the machine reports about itself: its CPU, cores, caches and memory.

Read once per process, from the kernel (``/proc/cpuinfo``,
``/sys/devices/system/cpu/cpu0/cache``; ``os.sysconf`` where sysfs is missing), never
measured: the sizes that depend on the machine (:mod:`pathtracer.render.sizes`, the
all-pairs chunks of :mod:`pathtracer.accel.small_mesh`) are chosen from it at run time,
and every speed figure names the CPU it was measured on.
"""
from __future__ import annotations

import functools
import os
from dataclasses import dataclass
from pathlib import Path

#: Where Linux describes CPU 0's caches, one ``index*`` folder per cache.
CACHE_FOLDER = Path("/sys/devices/system/cpu/cpu0/cache")
#: ``os.sysconf`` names of the data caches, the fallback where sysfs is missing. Some
#: hypervisors report another L3 here than in sysfs (268 MB against sysfs's 32 MB on the
#: AMD EPYC VM of docs/performance.md), so sysfs comes first.
SYSCONF_CACHES = {"L1d": "SC_LEVEL1_DCACHE_SIZE", "L2": "SC_LEVEL2_CACHE_SIZE",
                  "L3": "SC_LEVEL3_CACHE_SIZE"}
_UNITS = {"K": 1 << 10, "M": 1 << 20, "G": 1 << 30}


@dataclass(frozen=True)
class Machine:
    """The CPU model, logical cores and data cache sizes (bytes; None where unknown).

    ``L1d`` and ``L2`` are one core's; ``L3`` is the whole cache, shared by
    ``L3_sharing`` logical CPUs.
    """

    cpu: str
    cores: int
    L1d: int | None = None
    L2: int | None = None
    L3: int | None = None
    L3_sharing: int = 1

    def describe(self) -> str:
        """One line, e.g. ``AMD EPYC, 2 cores, L1d 32 KB, L2 512 KB per core, L3 32 MB``."""
        parts = [self.cpu, f"{self.cores} cores"]
        for name, size, scope in (("L1d", self.L1d, ""), ("L2", self.L2, " per core"),
                                  ("L3", self.L3, "")):
            parts.append(f"{name} {format_size(size)}{scope}" if size else f"{name} unknown")
        return ", ".join(parts)


@functools.lru_cache(maxsize=None)
def this_machine() -> Machine:
    """The machine this process runs on (read once)."""
    caches = read_caches(CACHE_FOLDER) or sysconf_caches()
    sizes = {name: size for name, (size, _) in caches.items()}
    return Machine(cpu=cpu_model(), cores=os.cpu_count() or 1, L1d=sizes.get("L1d"),
                   L2=sizes.get("L2"), L3=sizes.get("L3"),
                   L3_sharing=caches.get("L3", (None, 1))[1])


def cpu_model(cpuinfo: str | Path = "/proc/cpuinfo") -> str:
    """The CPU's model name from ``cpuinfo`` ("unknown CPU" where there is none)."""
    try:
        with open(cpuinfo) as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def read_caches(folder: Path) -> dict[str, tuple[int, int]]:
    """``{"L1d": (bytes, sharing CPUs), "L2": ..., "L3": ...}`` from a sysfs cache folder.

    Instruction caches are left out; a cache whose files cannot be read or parsed is
    skipped, so a missing folder gives ``{}``.
    """
    found = {}
    for index in sorted(Path(folder).glob("index*")):
        try:
            level = int((index / "level").read_text())
            kind = (index / "type").read_text().strip()
            size = parse_size((index / "size").read_text())
            shared = (index / "shared_cpu_list").read_text() if (index / "shared_cpu_list").exists() else "0"
        except (OSError, ValueError):
            continue
        if kind == "Instruction":
            continue
        found[f"L{level}" + ("d" if kind == "Data" else "")] = (size, count_cpus(shared))
    return found


def sysconf_caches() -> dict[str, tuple[int, int]]:
    """The data caches ``os.sysconf`` knows (sharing unknown: 1), where sysfs is missing."""
    found = {}
    for name, key in SYSCONF_CACHES.items():
        try:
            size = os.sysconf(key)
        except (ValueError, OSError, AttributeError):
            continue
        if size > 0:
            found[name] = (size, 1)
    return found


def parse_size(text: str) -> int:
    """Bytes of a sysfs cache size such as ``"512K"``, ``"32768K"``, ``"8M"`` or ``"65536"``."""
    text = text.strip().upper()
    if text and text[-1] in _UNITS:
        return int(text[:-1]) * _UNITS[text[-1]]
    return int(text)


def count_cpus(cpu_list: str) -> int:
    """The number of CPUs in a sysfs list such as ``"0-1"`` or ``"0,4-7"``."""
    count = 0
    for part in cpu_list.strip().split(","):
        if not part:
            continue
        first, _, last = part.partition("-")
        count += int(last or first) - int(first) + 1
    return max(1, count)


def format_size(size: int) -> str:
    """``32 KB``, ``512 KB``, ``32 MB``: bytes in the largest binary unit that divides them."""
    for unit, factor in (("GB", 1 << 30), ("MB", 1 << 20), ("KB", 1 << 10)):
        if size >= factor and size % factor == 0:
            return f"{size // factor} {unit}"
    return f"{size} B"
