"""What the ``pathtracer`` and ``mitsuba-refs`` command lines share: help text with examples
kept as written, ``--version``, and "did you mean" in argparse's refusal of a misspelt choice."""
from __future__ import annotations

import argparse
import re
import textwrap

from .names import suggestion

__all__ = ["HelpFormatter", "add_version", "with_choice_hint"]

#: argparse's message for a value outside ``choices`` (Python 3.10 to 3.13 spell it so).
_INVALID_CHOICE = re.compile(r"invalid choice: '(?P<name>[^']*)' \(choose from (?P<names>.*)\)")


class HelpFormatter(argparse.HelpFormatter):
    """argparse's formatter, except that a paragraph of indented lines (examples, tables) is
    printed as written; prose paragraphs are wrapped to the terminal as usual."""

    def _fill_text(self, text, width, indent):
        paragraphs = []
        for paragraph in text.strip("\n").split("\n\n"):
            lines = paragraph.splitlines()
            if len(lines) > 1 or paragraph.startswith(" "):
                paragraphs.append("\n".join(indent + line for line in lines))
            else:
                paragraphs.append(textwrap.fill(" ".join(paragraph.split()), width,
                                                initial_indent=indent, subsequent_indent=indent))
        return "\n\n".join(paragraphs)


def add_version(parser: argparse.ArgumentParser, version: str) -> None:
    """``--version``: the program and the package's ``version``."""
    parser.add_argument("--version", action="version", version=f"%(prog)s {version}")


def with_choice_hint(message: str) -> str:
    """argparse's error ``message`` with "did you mean" added when it refuses a misspelt choice
    (an integrator, a subcommand, a ``--bounces`` rule)."""
    found = _INVALID_CHOICE.search(message)
    if not found:
        return message
    names = [n.strip().strip("'\"") for n in found["names"].split(",")]
    hint = suggestion(found["name"], names).strip()
    return f"{message}; {hint}" if hint else message
