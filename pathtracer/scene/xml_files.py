"""The files of a scene: one XML file read into :class:`Element` objects (with the file
and line of each), and where an ``<include>``d file is found.

:mod:`pathtracer.scene.xml` turns the elements into plugins; the reference harness reads
the same elements and follows ``<include>`` by the same rule (:func:`scene_tree`,
:func:`scene_files`), so that both renderers' inputs and a reference's cache key agree
on which files a scene reads.
"""
from __future__ import annotations

import glob
import os
import re
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
        raise XMLSyntaxError(expat.ErrorString(e.code), display, e.lineno, e.offset + 1) from None
    return roots[0]


class XMLSyntaxError(SceneError):
    """A file that is not well-formed XML; ``syntax`` is expat's reason, ``column`` 1-based."""

    def __init__(self, syntax: str, file: str | None = None, line: int | None = None,
                 column: int | None = None):
        text = syntax if column is None else f"XML syntax error: {syntax} (column {column})"
        super().__init__(text, file, line)
        self.syntax, self.column = syntax, column


def walk(root: Element):
    """``root`` and every element inside it, in document order."""
    yield root
    for child in root.children:
        yield from walk(child)


#: Mitsuba stops at this include depth; deeper nesting is a cycle or a mistake.
MAX_INCLUDE_DEPTH = 15


@dataclass
class FileState:
    """Where the reader is: the include chain down to the file being read
    (real paths) and where that file's ``<include>``s are looked up.

    ``lookup`` is this file's part of Mitsuba's file resolver, first match
    wins: this file's ``<path>`` folders (last first, each from where it
    stands on), this file's folder, then the including file's list. An
    ``<include>`` tries the including file's folder before all of them.
    """

    lookup: list[str]
    chain: tuple[str, ...]

    @classmethod
    def top(cls, path: str) -> "FileState":
        """The state of the top-level file ``path``: its folder, then the working directory."""
        return cls([os.path.dirname(os.path.abspath(path)), os.getcwd()], (os.path.realpath(path),))

    def add_path(self, folder: str) -> None:
        """A ``<path>`` of this file: looked in first from here on."""
        self.lookup.insert(0, folder)

    def include_lookup(self, el: Element) -> list[str]:
        """The folders an ``<include>`` element ``el`` is looked up in, first match wins."""
        return [el.folder] + self.lookup

    def enter(self, el: Element, target: str, top_dir: str) -> tuple[Element, "FileState"]:
        """Read the file ``target`` that ``el`` includes: its root element and its state.

        Raises
        ------
        SceneError
            On an include cycle (or nesting deeper than Mitsuba's limit), located at ``el``.
        """
        real = os.path.realpath(target)
        if real in self.chain or len(self.chain) > MAX_INCLUDE_DEPTH:
            cycle = " -> ".join(os.path.basename(p) for p in self.chain + (real,))
            raise SceneError(f"include cycle {cycle}", el.file, el.line, "<include>")
        root = read_elements(target, display_name(target, top_dir))
        return root, FileState([root.folder] + self.lookup, self.chain + (real,))


def display_name(path: str, top_dir: str) -> str:
    """The name messages give an included file: relative to the top-level scene's folder
    ``top_dir`` (``parts/bad.xml``, ``../lib/mid.xml``), as docs/scene-format.md says; an
    absolute path only where none relative exists (another drive on Windows)."""
    try:
        return os.path.relpath(os.path.abspath(path), top_dir)
    except ValueError:
        return os.path.abspath(path)


def find_in(name: str, folders: list[str]) -> str | None:
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


def path_folder(el: Element, value: str) -> str:
    """The folder a ``<path value="...">`` element names (relative to its file's folder)."""
    return os.path.normpath(os.path.join(el.folder, value))


def resolve_folder(el: Element, value: str, lookup: list[str]) -> tuple[str | None, list[str]]:
    """The folder a ``<path value="...">`` names, as Mitsuba resolves it: relative to its
    file's folder first, else the first folder of the file resolver ``lookup`` (a
    :attr:`FileState.lookup`) where it exists; None where it exists nowhere.

    An included file's ``<path value="../../common"/>`` written relative to the top-level
    scene is found that way (Mitsuba's ``fs->resolve``). Returns ``(folder, tried)``.
    """
    tried = [path_folder(el, value)]
    if os.path.isdir(tried[0]):
        return tried[0], tried
    if not os.path.isabs(value):
        for folder in lookup:
            candidate = os.path.normpath(os.path.join(folder, value))
            if candidate not in tried:
                tried.append(candidate)
                if os.path.isdir(candidate):
                    return candidate, tried
    return None, tried


def search_paths(root: Element) -> list[str]:
    """The folders of the top-level file's ``<path>`` elements, the last one first: where
    file names other than ``<include>``s (meshes, textures) are looked up first; a
    ``$param`` folder or one that does not exist is left out (the loader refuses it)."""
    folders = [resolve_folder(el, el.attrs.get("value", ""), [os.getcwd()])[0]
               for el in root.children if el.tag == "path" and "$" not in el.attrs.get("value", "$")]
    return [folder for folder in folders if folder is not None][::-1]


def scene_tree(path: str) -> Element:
    """The root element of the scene file ``path`` with the content of every ``<include>``
    spliced in where it stands, as the loader reads it. An include the loader could not
    resolve without the scene's parameters (a ``$param`` in its name), or that names no
    file, stays an ``<include>`` element.

    Raises
    ------
    SceneError
        A file that is not well-formed (:class:`XMLSyntaxError`), or an include cycle.
    """
    return _read_scene(path)[0]


def scene_files(path: str) -> list[str]:
    """The files the scene file ``path`` reads, in document order, as real paths: every
    ``<include>`` (followed by the files it reads) and every ``<string name="filename">``,
    as often as they appear.

    An include is found by the loader's rule (:class:`FileState`), any other file in the
    top-level file's ``<path>`` folders (the last one first), the scene's folder, then the
    working directory (:func:`pathtracer.scene.properties.search_folders`). A file found
    nowhere is listed where it was first looked for. A name with a ``$param`` lists every
    existing file it could name, sorted (their includes are not followed).
    """
    return _read_scene(path)[1]


def _read_scene(path: str) -> tuple[Element, list[str]]:
    root = read_elements(path, os.path.basename(path))
    top_dir = os.path.dirname(os.path.abspath(path))
    folders = search_paths(root) + [top_dir, os.getcwd()]
    files: list[str] = []
    _splice(root, FileState.top(path), folders, top_dir, files)
    return root, files


def _splice(root: Element, state: FileState, folders: list[str], top_dir: str, files: list[str]) -> None:
    """Follow the includes of one file's ``root`` (in place), collecting ``files``."""

    def visit(el: Element, top: bool) -> None:
        children = []
        for child in el.children:
            value = child.attrs.get("value", "")
            if top and child.tag == "path" and "$" not in value:
                folder = resolve_folder(child, value, state.lookup)[0]
                if folder is not None:
                    state.add_path(folder)
            if child.tag == "string" and child.attrs.get("name") == "filename" and value:
                files.extend(_lookup(value, folders))
            if child.tag == "include" and child.attrs.get("filename"):
                inner = _include(child, state, folders, top_dir, files)
                if inner is not None:
                    children.extend(inner.children)
                    continue
            visit(child, top=False)
            children.append(child)
        el.children = children

    visit(root, top=True)


def _include(el: Element, state: FileState, folders: list[str], top_dir: str,
             files: list[str]) -> Element | None:
    """List the file ``el`` includes and the files it reads; its root, or None where not followed."""
    name = el.attrs["filename"]
    lookup = state.include_lookup(el)
    if "$" in name:
        files.extend(_lookup(name, lookup))
        return None
    target = find_in(name, lookup)
    if target is None:
        files.append(os.path.realpath(os.path.join(lookup[0], name)))
        return None
    files.append(os.path.realpath(target))
    root, inner = state.enter(el, target, top_dir)
    _splice(root, inner, folders, top_dir, files)
    return root


def _lookup(name: str, folders: list[str]) -> list[str]:
    """The file ``name`` names in ``folders`` (first match, else where first looked for);
    every file a ``$param`` name could name."""
    if "$" in name:
        pattern = re.sub(r"\$\w+", "*", name)
        return sorted({os.path.realpath(p) for folder in folders
                       for p in glob.glob(os.path.join(glob.escape(folder), pattern)) if os.path.isfile(p)})
    found = find_in(name, folders)
    return [os.path.realpath(found if found is not None else os.path.join(folders[0], name))]
