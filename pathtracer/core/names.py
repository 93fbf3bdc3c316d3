"""The "did you mean" of every lookup by name: scenes, integrators, plugins, presets, choices."""
from __future__ import annotations

import difflib
from collections.abc import Iterable

__all__ = ["did_you_mean", "suggestion"]


def did_you_mean(name: str, names: Iterable[str]) -> str | None:
    """The known name closest to ``name`` (a misspelling of it), or None when none is close."""
    known = [str(n) for n in names]
    close = difflib.get_close_matches(str(name), known, n=1, cutoff=0.6)
    if not close:
        # A different case only ("Cornell-Box") is below difflib's cutoff for short names.
        close = [n for n in known if n.lower() == str(name).lower()]
    return close[0] if close else None


def suggestion(name: str, names: Iterable[str]) -> str:
    """``"did you mean 'x'? "`` for a misspelt ``name``, or ``""``: put before the list of names."""
    close = did_you_mean(name, names)
    return f"did you mean '{close}'? " if close else ""

