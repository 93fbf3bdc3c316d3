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

__all__ = ["depth_name", "first_diverging_bounce"]


def depth_name(depth: int) -> str:
    """Human name of a Mitsuba max_depth."""
    if depth < 0:
        return "full paths (unbounded depth)"
    if depth == 0:
        return "nothing (depth 0)"
    if depth == 1:
        return "directly visible emitters (bounce 1)"
    if depth == 2:
        return "direct light (bounce 2)"
    if depth == 3:
        return "one indirect bounce (bounce 3)"
    return f"{depth - 2} indirect bounces (bounce {depth})"


def first_diverging_bounce(results: Mapping[int, object]) -> tuple[int | None, str]:
    """First max_depth at which the two renderers disagree.

    Parameters
    ----------
    results : dict int -> MeanAgreement
        One comparison per max_depth (any object with ``agree``, ``p_value``, ``verdict``).
        -1 (unbounded) sorts last.

    Returns
    -------
    depth : int or None
        The smallest disagreeing depth, None if all agree.
    text : str
        e.g. "direct light (bounce 2) already disagrees (p=3e-09): ...; directly visible
        emitters (bounce 1) agree".
    """
    if not results:
        return None, "no depths compared"
    order = sorted(results, key=lambda d: (d < 0, d))
    bad = [d for d in order if not results[d].agree]
    if not bad:
        return None, f"all depths agree ({', '.join(str(d) for d in order)})"
    first = bad[0]
    r = results[first]
    ok_below = [d for d in order[:order.index(first)]]
    p = r.p_value
    ptxt = f"{p:.2g}" if p > 0 else "<1e-300"
    text = f"{depth_name(first)} {'already ' if first == order[0] else ''}disagrees (p={ptxt}): {r.verdict}"
    if ok_below:
        text += "; " + ", ".join(depth_name(d) for d in ok_below) + (" agrees" if len(ok_below) == 1 else " agree")
        text += f" -> look at what depth {first} adds"
    later_ok = [d for d in order[order.index(first) + 1:] if results[d].agree]
    if later_ok:
        text += (f"; note: deeper depths {later_ok} agree again (a small error at depth {first} can drown in "
                 "more noise deeper, not a contradiction)")
    return first, text
