r"""The seeds of an external renderer's runs: chosen so that no run can replay another's streams.

A renderer turns ``{seed}`` into one random stream per pixel (or per sample) by some rule of
its own. Seeds that are merely *distinct* are not enough: with the rules below, seed
:math:`s + 1` replays the streams of seed :math:`s` one pixel further on, and two such images
share their noise at a pixel offset (Mitsuba 3's command line with consecutive seeds: residuals
correlated 0.65 between neighbouring pixels, and a mean test that fails at p = 5e-7).

Film :math:`W \times H`, :math:`P = W H` pixels, :math:`\hat P = \lceil W/32\rceil
\lceil H/32\rceil \cdot 1024` pixels of the film padded to 32 x 32 blocks, :math:`n` samples
per pixel, all arithmetic on 32-bit unsigned integers (it wraps modulo :math:`2^{32}`). The
streams a run of seed :math:`s` uses are:

* **seed + pixel index** (row-major, or block-local in Morton order over padded blocks, which is
  what Mitsuba 3's scalar renderer does with the sampler's ``seed`` property, the one ``-D
  seed=`` sets): :math:`[s,\ s + \hat P)`;
* **seed x pixel count + block offset** (Mitsuba 3's scalar ``render(seed=s)``: it multiplies
  the seed by :math:`P` and seeds the padded block :math:`b`'s pixel :math:`i` with
  :math:`sP + 1024 b + i`): :math:`[sP,\ sP + \hat P) \bmod 2^{32}`;
* **seed + sample index** (one stream per sample number, shared by the pixels):
  :math:`[s,\ s + n)`;
* **hashed seeds** (Mitsuba's JIT variants, ``pathtracer``): a hash of :math:`s` and the
  pixel; any two distinct seeds give distinct streams.

The seeds of one check are :math:`s_m = b + m T` for slots :math:`m = 1 \dots M` (one slot per
run, in the order the runs are made). Every condition above depends only on the differences
:math:`(m - m') T` of two seeds, so the base :math:`b` is free and the stride :math:`T` is the
smallest integer with

.. math::

    T \ge \max(\hat P, n), \qquad
    \min_{1 \le d < M} \operatorname{dist}\left(d\,T P \bmod 2^{32},\ 0\right) \ge \hat P,

where dist is the distance on the circle of :math:`2^{32}` integers. The first condition keeps
the pixel and sample ranges apart; the second the ranges of the multiplied seeds, wrapping
included (for a 1024 x 1024 film :math:`T = 2^{20}` fails it: every :math:`s P` is 0 modulo
:math:`2^{32}`; :math:`T = 2^{20} + 1` passes). Seeds stay below :math:`2^{31}` (Mitsuba's
``seed`` is an ``int`` property), so :math:`s + \hat P` never wraps.

Repeated checks (``seed_offset`` :math:`o`, e.g. a calibration) take the :math:`o`-th of the
:math:`K = \lfloor (2^{31} - T) / (T M) \rfloor` disjoint ranges of :math:`M` slots; past
:math:`K` they start again, shifted by less than :math:`T` (fresh seeds, still disjoint within
the check).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Seeds stay below this (Mitsuba's ``seed`` is a 32-bit signed ``int`` property).
SEED_LIMIT = 2 ** 31
#: Unsigned 32-bit arithmetic wraps modulo this.
WRAP = 2 ** 32
#: Mitsuba 3's scalar renderer seeds its film in blocks of BLOCK x BLOCK pixels.
BLOCK = 32
#: Fewest slots a rule provides (a check's runs, or a user's images).
MIN_SLOTS = 256
#: How far past max(padded pixels, spp) the stride is searched for.
STRIDE_SEARCH = 1 << 16
#: The sub-stride shift of the seeds of repeated checks beyond the disjoint ranges (odd, so
#: that successive rounds differ).
ROUND_SHIFT = 0x9E3779B1


class SeedSpaceError(ValueError):
    """The film is too large for this many runs with disjoint streams below :data:`SEED_LIMIT`."""


def padded_pixels(width: int, height: int) -> int:
    """Pixels of a ``width`` x ``height`` film padded to whole :data:`BLOCK` x BLOCK blocks."""
    return math.ceil(width / BLOCK) * math.ceil(height / BLOCK) * BLOCK * BLOCK


def spreads_multiplied_seeds(stride: int, pixels: int, padded: int, slots: int) -> bool:
    """Whether seeds ``stride`` apart, multiplied by ``pixels`` modulo 2^32, stay ``padded``
    apart on the circle for every difference of fewer than ``slots`` strides."""
    step = (stride * pixels) % WRAP
    starts = (np.arange(1, slots, dtype=np.uint64) * np.uint64(step)) % np.uint64(WRAP)
    distance = np.minimum(starts, np.uint64(WRAP) - starts)
    return bool(np.all(distance >= padded))


@dataclass(frozen=True)
class SeedRule:
    """The seeds of one check (module docstring).

    Attributes
    ----------
    width, height : int
        The film.
    max_spp : int
        The largest sample count of a run.
    slots : int
        ``M``: how many runs the seeds keep apart.
    stride : int
        ``T``: the distance between two seeds.
    offset : int
        The check's ``seed_offset`` (repeated checks), the default of the methods' ``offset``.
    """

    width: int
    height: int
    max_spp: int
    slots: int
    stride: int
    offset: int = 0

    @property
    def rounds(self) -> int:
        """``K``: checks with pairwise disjoint seed ranges before the ranges are reused."""
        return max(1, (SEED_LIMIT - self.stride) // (self.stride * self.slots))

    def base(self, offset: int | None = None) -> int:
        """``b``: the seeds of the check with ``seed_offset`` ``offset`` are ``b + m T``."""
        offset = self.offset if offset is None else int(offset)
        round_, range_ = divmod(offset, self.rounds)
        return self.stride * self.slots * range_ + (round_ * ROUND_SHIFT) % self.stride

    def seed(self, slot: int, offset: int | None = None) -> int:
        """The seed of run ``slot`` (0-based) of the check with ``seed_offset`` ``offset``."""
        if not 0 <= slot < self.slots:
            raise SeedSpaceError(f"run {slot + 1} of a check planned for {self.slots} runs")
        return self.base(offset) + self.stride * (slot + 1)

    def seeds(self, count: int, offset: int | None = None) -> list[int]:
        """The first ``count`` seeds."""
        return [self.seed(slot, offset) for slot in range(count)]


def seed_rule(width: int, height: int, max_spp: int, runs: int = MIN_SLOTS, *,
              fit: bool = False) -> SeedRule:
    """The :class:`SeedRule` of a ``width`` x ``height`` film, runs of at most ``max_spp``
    samples per pixel and at most ``runs`` runs (at least :data:`MIN_SLOTS`; with ``fit``, as
    many of them as the film leaves room for: a check that grows past them is refused then,
    not before).

    Raises
    ------
    SeedSpaceError
        When no stride keeps that many runs (``fit``: one run) apart below :data:`SEED_LIMIT`.
    """
    width, height, max_spp = int(width), int(height), max(1, int(max_spp))
    padded = padded_pixels(width, height)
    smallest = max(padded, max_spp)
    wanted = max(MIN_SLOTS, int(runs))
    most = (SEED_LIMIT - 1) // smallest - 1
    slots = max(1, min(wanted, most)) if fit else wanted
    while True:
        stride = _stride(width * height, padded, smallest, slots)
        if stride is not None:
            return SeedRule(width, height, max_spp, slots, stride)
        if not fit or slots <= 1:
            break
        slots = max(1, slots * 7 // 8)
    raise SeedSpaceError(f"a {width}x{height} film at up to {max_spp} spp leaves room for at most "
                         f"{max(0, most)} runs with disjoint random streams below 2^31; {slots} were "
                         "needed")


def _stride(pixels: int, padded: int, smallest: int, slots: int) -> int | None:
    """The smallest stride from ``smallest`` on that keeps ``slots`` runs apart, or None."""
    for stride in range(smallest, smallest + STRIDE_SEARCH):
        if stride * (slots + 1) >= SEED_LIMIT:
            return None
        if spreads_multiplied_seeds(stride, pixels, padded, slots):
            return stride
    return None
