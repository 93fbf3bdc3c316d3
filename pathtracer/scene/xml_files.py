"""The files of a scene: one XML file read into :class:`Element` objects (with the file
and line of each), and where an ``<include>``d file is found.

:mod:`pathtracer.scene.xml` turns the elements into plugins.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from xml.parsers import expat

from .errors import SceneError


@dataclass
class Element:
    """A raw XML element with the file and line it starts on.

    ``file`` is the name shown in messages, ``folder`` the absolute directory
    of that file (relative ``<include>`` and ``<path>`` values start there).
    """

    tag: str
    attrs: dict[str, str]
    line: int
    children: list["Element"] = field(default_factory=list)
    file: str = ""
    folder: str = ""


def read_elements(path: str, display: str) -> Element:
    """Parse an XML file into :class:`Element` objects with line numbers.

    ``display`` is the file name shown in error messages.

    Raises
    ------
    SceneError
        On an XML syntax error, with the line reported by expat.
    """
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise SceneError(f"cannot read the scene file: {e.strerror or e}", display) from None
    parser = expat.ParserCreate()
    stack: list[Element] = []
    roots: list[Element] = []
    folder = os.path.dirname(os.path.abspath(path))

    def start(tag, attrs):
        el = Element(tag, dict(attrs), parser.CurrentLineNumber, file=display, folder=folder)
        (stack[-1].children if stack else roots).append(el)
        stack.append(el)

    def end(tag):
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(data, True)
    except expat.ExpatError as e:
        raise SceneError(f"XML syntax error: {expat.ErrorString(e.code)} (column {e.offset + 1})",
                         display, e.lineno) from None
    return roots[0]


#: Mitsuba stops at this include depth; deeper nesting is a cycle or a mistake.
MAX_INCLUDE_DEPTH = 15


@dataclass
class _FileState:
    """Where the reader is: the include chain down to the file being read
    (real paths) and where that file's ``<include>``s are looked up.

    ``lookup`` is this file's part of Mitsuba's file resolver, first match
    wins: this file's ``<path>`` folders (last first), this file's folder,
    then the including file's list. An ``<include>`` tries the including
    file's folder before all of them.
    """

    lookup: list[str]
    chain: tuple[str, ...]


def _find(name: str, folders: list[str]) -> str | None:
    """The first existing ``folder/name`` (Mitsuba's FileResolver), or None.

    An absolute ``name`` is returned as is when it exists.
    """
    if os.path.isabs(name):
        return name if os.path.isfile(name) else None
    for folder in folders:
        candidate = os.path.join(folder, name)
        if os.path.isfile(candidate):
            return candidate
    return None
