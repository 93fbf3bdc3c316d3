"""The command lines' ``-D name=value`` options: one rule for every tool that takes them."""
from __future__ import annotations

__all__ = ["parse_define", "parse_defines"]


def parse_define(text: str) -> tuple[str, str]:
    """Split one ``-D`` option into its scene parameter name and value.

    Parameters
    ----------
    text : str
        ``"name=value"``; spaces around the name and the value are dropped, the value may
        be empty or hold further ``=`` signs.

    Returns
    -------
    (str, str)
        The name and the value, as text (the scene loader converts and checks the value
        where the file uses it, naming file and line).

    Raises
    ------
    ValueError
        Without ``=`` or without a name, in one line quoting ``text``.
    """
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise ValueError(f"-D expects name=value, got {text!r}")
    return name.strip(), value.strip()


def parse_defines(texts) -> dict[str, str]:
    """``["name=value", ...]`` (repeated ``-D`` options, or None) as a dict; a later name wins.

    Raises
    ------
    ValueError
        For the first malformed option (see :func:`parse_define`).
    """
    return dict(parse_define(text) for text in texts or ())
