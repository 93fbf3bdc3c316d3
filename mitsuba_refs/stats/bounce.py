"""Which bounce breaks first?  Read a max_depth sweep of mean comparisons.

Mitsuba's ``max_depth`` counts path vertices: 1 = directly visible emitters, 2 = direct
lighting (one bounce off a surface towards a light), 3 = one indirect bounce, k = k-2
indirect bounces; -1 = unbounded.  Rendering both sides at max_depth = 1, 2, 3, ... and
comparing each pair isolates the first depth at which the two disagree: everything below it
is verified, the bug lives in what that depth adds.  Pure function, no I/O.

Multiple testing: each MeanAgreement carries its own alpha; budget them with
:mod:`mitsuba_refs.stats.budget` (count every depth as one registered test).
"""
from __future__ import annotations

from typing import Mapping

__all__ = ["depth_order", "first_diverging_bounce"]


def depth_order(depths) -> list:
    """The depths in sweep order: increasing, -1 (unbounded) last."""
    return sorted(depths, key=lambda d: (d < 0, d))


def first_diverging_bounce(results: Mapping[int, object]) -> int | None:
    """First max_depth at which the two renderers disagree.

    Parameters
    ----------
    results : dict int -> MeanAgreement
        One comparison per max_depth (any object with ``agree``). -1 (unbounded) sorts last.

    Returns
    -------
    int or None
        The smallest disagreeing depth, None if all agree (the words:
        :func:`mitsuba_refs.report.wording.bounce_verdict`).
    """
    bad = [d for d in depth_order(results) if not results[d].agree]
    return bad[0] if bad else None
