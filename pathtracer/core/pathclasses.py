r"""Heckbert's path classes: regular expressions over path vertices, compiled to DFAs.

A light path is written as the string of its vertices from the light to the
eye (Heckbert 1990, the lecture's "Heckbert's Classification" slides)::

    L   a light source          (an emitter hit, a light sample, the environment)
    D   a diffuse reflection    (``diffuse``; also ``plastic``, whose letter is its
        diffuse lobe: a letter belongs to a BSDF, not to the lobe sampled)
    S   a specular event        (``conductor``, ``dielectric``, ``thindielectric``: Dirac lobes)
    G   a glossy reflection     (``roughconductor``, ``roughdielectric``, ``roughplastic``),
        unless folded into D or S
    E   the eye

Syntax of a class expression (whitespace is ignored)::

    L D S G E     one vertex of that kind
    .             any scattering vertex, i.e. (D|S|G)
    [DS]          one of the listed letters
    (r)  r|s      grouping, alternation
    r*  r+  r?    zero or more, one or more, zero or one

Examples (the lecture's): direct lighting ``LDE``, indirect diffuse ``LDD+E``,
caustics ``LS+DE``, specular chains ``LS*E``, everything ``L(D|S)*E`` (or
``L.*E`` when glossy surfaces are present). The whole path must match.

A path tracer builds paths from the eye, so the expression is *reversed*
(``LS+DE`` becomes ``ED S+ L``) and compiled into a deterministic finite
automaton whose transition table is a NumPy array: every path in a wavefront
carries its DFA state, each new vertex is one table lookup
``state = delta[state, letter]`` for the whole batch, and a contribution
(an emitter hit, or a shadow ray) counts in a class iff the state after
appending ``L`` is accepting.

The letters of a scene's BSDFs, and the automaton states of subpaths in one scene, are
:mod:`pathtracer.integrators.path_letters`.
"""
from __future__ import annotations

import functools
import itertools
from dataclasses import dataclass

import numpy as np

#: The alphabet, in the column order of the transition tables.
ALPHABET = "LDSGE"
LETTER = {c: i for i, c in enumerate(ALPHABET)}
SCATTERING = "DSG"

#: The lecture's named classes (regex -> description).
LECTURE_CLASSES = {
    "LE": "emitters seen directly",
    "LDE": "direct lighting on diffuse surfaces",
    "LDD+E": "indirect diffuse (inter-reflections)",
    "LS+DE": "caustics",
    "LS*E": "specular chains (lights seen in mirrors and glass)",
    "L(D|S|G)*E": "everything",
}


class PathRegexError(ValueError):
    """A malformed path expression (the message points at the offending character)."""


# ---------------------------------------------------------------------------------------
# parsing: expression -> tree of ('sym', frozenset) | ('cat', [..]) | ('alt', [..])
#          | ('star', t) | ('plus', t) | ('opt', t) | ('eps',)

class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.chars = [(i, c) for i, c in enumerate(text) if not c.isspace()]
        self.pos = 0

    def error(self, message: str):
        where = self.chars[self.pos][0] if self.pos < len(self.chars) else len(self.text)
        raise PathRegexError(f"path expression {self.text!r}: {message} at column {where + 1}")

    def peek(self):
        return self.chars[self.pos][1] if self.pos < len(self.chars) else None

    def parse(self):
        if not self.chars:
            raise PathRegexError("empty path expression")
        tree = self.alternation()
        if self.peek() is not None:
            self.error(f"unexpected {self.peek()!r}")
        return tree

    def alternation(self):
        parts = [self.concatenation()]
        while self.peek() == "|":
            self.pos += 1
            parts.append(self.concatenation())
        return parts[0] if len(parts) == 1 else ("alt", parts)

    def concatenation(self):
        parts = []
        while self.peek() is not None and self.peek() not in "|)":
            parts.append(self.repetition())
        if not parts:
            return ("eps",)
        return parts[0] if len(parts) == 1 else ("cat", parts)

    def repetition(self):
        node = self.atom()
        while self.peek() is not None and self.peek() in "*+?":
            op = {"*": "star", "+": "plus", "?": "opt"}[self.peek()]
            self.pos += 1
            node = (op, node)
        return node

    def atom(self):
        c = self.peek()
        if c is None:
            self.error("expression ends early")
        if c == "(":
            self.pos += 1
            node = self.alternation()
            if self.peek() != ")":
                self.error("missing ')'")
            self.pos += 1
            return node
        if c == "[":
            self.pos += 1
            letters = set()
            while self.peek() is not None and self.peek() != "]":
                letters.add(self.letter())
            if self.peek() != "]":
                self.error("missing ']'")
            self.pos += 1
            if not letters:
                self.error("empty letter set []")
            return ("sym", frozenset(letters))
        if c == ".":
            self.pos += 1
            return ("sym", frozenset(SCATTERING))
        if c in "*+?":
            self.error(f"{c!r} repeats nothing")
        if c == ")":
            self.error("unbalanced ')'")
        return ("sym", frozenset(self.letter()))

    def letter(self):
        c = self.peek().upper()
        if c not in ALPHABET:
            self.error(f"unknown vertex letter {self.peek()!r} (use {', '.join(ALPHABET)}, '.')")
        self.pos += 1
        return c


def parse(expression: str):
    """Parse a path expression into a syntax tree (raises :class:`PathRegexError`)."""
    return _Parser(expression).parse()


def reverse(tree):
    """The tree of the reversed language (concatenations read backwards)."""
    kind = tree[0]
    if kind == "cat":
        return ("cat", [reverse(t) for t in reversed(tree[1])])
    if kind == "alt":
        return ("alt", [reverse(t) for t in tree[1]])
    if kind in ("star", "plus", "opt"):
        return (kind, reverse(tree[1]))
    return tree


# ---------------------------------------------------------------------------------------
# Thompson NFA and subset construction

class _NFA:
    def __init__(self):
        self.eps = []      # state -> list of states
        self.edges = []    # state -> list of (letters, state)

    def new(self) -> int:
        self.eps.append([])
        self.edges.append([])
        return len(self.eps) - 1

    def build(self, tree) -> tuple[int, int]:
        """Fragment (start, end) recognising ``tree``."""
        kind = tree[0]
        if kind == "sym":
            s, e = self.new(), self.new()
            self.edges[s].append((tree[1], e))
            return s, e
        if kind == "eps":
            s, e = self.new(), self.new()
            self.eps[s].append(e)
            return s, e
        if kind == "cat":
            first_s, prev_e = self.build(tree[1][0])
            for part in tree[1][1:]:
                s, e = self.build(part)
                self.eps[prev_e].append(s)
                prev_e = e
            return first_s, prev_e
        if kind == "alt":
            s, e = self.new(), self.new()
            for part in tree[1]:
                ps, pe = self.build(part)
                self.eps[s].append(ps)
                self.eps[pe].append(e)
            return s, e
        inner_s, inner_e = self.build(tree[1])
        s, e = self.new(), self.new()
        self.eps[s].append(inner_s)
        self.eps[inner_e].append(e)
        if kind in ("star", "opt"):
            self.eps[s].append(e)
        if kind in ("star", "plus"):
            self.eps[inner_e].append(inner_s)
        return s, e

    def closure(self, states) -> frozenset:
        stack, seen = list(states), set(states)
        while stack:
            for t in self.eps[stack.pop()]:
                if t not in seen:
                    seen.add(t)
                    stack.append(t)
        return frozenset(seen)


@dataclass(frozen=True, eq=False)
class PathClass:
    """A compiled path class.

    Attributes
    ----------
    expression : str
        The class in Heckbert's notation, as written (light first).
    delta : (n_states, 5) int32
        Transition table of the DFA of the *reversed* expression (eye first);
        columns follow :data:`ALPHABET`. State 0 is the dead state.
    accept : (n_states,) bool
    start : int
    """

    expression: str
    delta: np.ndarray
    accept: np.ndarray
    start: int

    @property
    def n_states(self) -> int:
        return int(self.delta.shape[0])

    def step(self, state: np.ndarray, letter) -> np.ndarray:
        """States after reading ``letter`` (a letter, a code, or an array of codes per path)."""
        if isinstance(letter, str):
            letter = LETTER[letter]
        return self.delta[state, letter]

    def matches(self, path: str) -> bool:
        """Whether the string ``path`` (light first, e.g. ``'LDSE'``) is in the class."""
        state = self.start
        for c in reversed(path.upper()):
            if c not in LETTER:
                raise PathRegexError(f"unknown vertex letter {c!r} in path {path!r}")
            state = int(self.delta[state, LETTER[c]])
        return bool(self.accept[state])

    def __repr__(self) -> str:
        return f"PathClass({self.expression!r}, {self.n_states} states)"


def _compile_tree(tree) -> tuple[np.ndarray, np.ndarray]:
    """Subset construction: (transition table, accepting states) of a syntax tree's DFA.

    State 0 is the dead state, state 1 the start."""
    nfa = _NFA()
    start, end = nfa.build(tree)
    dead = frozenset()
    first = nfa.closure([start])
    index = {dead: 0, first: 1}
    order = [dead, first]
    rows = []
    i = 0
    while i < len(order):
        current = order[i]
        row = []
        for c in ALPHABET:
            moved = [t for s in current for letters, t in nfa.edges[s] if c in letters]
            target = nfa.closure(moved) if moved else dead
            if target not in index:
                index[target] = len(order)
                order.append(target)
            row.append(index[target])
        rows.append(row)
        i += 1
    delta = np.array(rows, dtype=np.int32)
    accept = np.array([end in states for states in order], dtype=bool)
    return delta, accept


def compile_class(expression: str) -> PathClass:
    """Compile a path expression (light first) into the DFA of its reversal (eye first)."""
    delta, accept = _compile_tree(reverse(parse(expression)))
    return PathClass(expression, delta, accept, 1)


def compile_classes(expressions) -> list[PathClass]:
    """Compile several expressions (a single string is one class)."""
    if isinstance(expressions, str):
        expressions = [expressions]
    return [e if isinstance(e, PathClass) else compile_class(e) for e in expressions]


@dataclass(frozen=True, eq=False)
class JoinedClass:
    """A path class read from both ends, for light tracing and BDPT.

    A light subpath reads its vertices from the light (``L`` first) with the DFA of the
    expression as written; a camera subpath reads them from the eye (``E`` first) with
    :attr:`camera`, the DFA of the reversal. Joining a light prefix u that left the first
    automaton in state a with a camera prefix v that left the second in state b gives a
    path of the class iff ``join[a, b]``: the state a fixes every suffix u can be completed
    with, b every prefix v can be, so the answer depends on the two states only and is
    tabulated from one shortest string reaching each of them.

    Attributes
    ----------
    expression : str
    light_delta : (n_light_states, 5) int32
        Transition table of the expression's DFA (light first); state 1 is the start.
    camera : PathClass
        The DFA of the reversal (:func:`compile_class`).
    join : (n_light_states, camera.n_states) bool
    """

    expression: str
    light_delta: np.ndarray
    camera: PathClass
    join: np.ndarray

    start = 1

    def light_step(self, state, letter) -> np.ndarray:
        """Light-side states after reading ``letter`` (a letter or per-path codes)."""
        return self.light_delta[state, LETTER[letter] if isinstance(letter, str) else letter]

    def camera_step(self, state, letter) -> np.ndarray:
        """Camera-side states after reading ``letter`` (a letter or per-path codes)."""
        return self.camera.step(state, letter)

    def accepts(self, light_state, camera_state) -> np.ndarray:
        """Whether joining the two prefixes gives a path of the class."""
        return self.join[light_state, camera_state]


def _shortest_strings(delta: np.ndarray, start: int) -> dict:
    """state -> a shortest string that reaches it from ``start`` (breadth first)."""
    found, frontier = {start: ""}, [start]
    while frontier:
        following = []
        for state in frontier:
            for code, letter in enumerate(ALPHABET):
                target = int(delta[state, code])
                if target not in found:
                    found[target] = found[state] + letter
                    following.append(target)
        frontier = following
    return found


@functools.lru_cache(maxsize=64)
def compile_joined(expression: str) -> JoinedClass:
    """Compile a path expression (light first) for subpaths grown from both ends."""
    camera = compile_class(expression)
    light_delta, _ = _compile_tree(parse(expression))
    join = np.zeros((len(light_delta), camera.n_states), dtype=bool)
    for a, prefix in _shortest_strings(light_delta, 1).items():
        for b, suffix in _shortest_strings(camera.delta, camera.start).items():
            join[a, b] = camera.matches(prefix + suffix[::-1])
    return JoinedClass(expression, light_delta, camera, join)


def enumerate_paths(max_vertices: int, letters: str = SCATTERING):
    """Every path string ``L x_k ... x_1 E`` with 0 <= k <= ``max_vertices`` scattering vertices."""
    for k in range(max_vertices + 1):
        for middle in itertools.product(letters, repeat=k):
            yield "L" + "".join(middle) + "E"


def is_partition(expressions, max_vertices: int = 6, letters: str = SCATTERING) -> tuple[bool, str]:
    """Check that the classes are disjoint and cover every path up to ``max_vertices`` bounces.

    Returns (ok, explanation): the first path matched by no class or by two.
    """
    classes = compile_classes(expressions)
    for path in enumerate_paths(max_vertices, letters):
        hits = [c.expression for c in classes if c.matches(path)]
        if len(hits) != 1:
            what = "no class" if not hits else f"several classes ({', '.join(hits)})"
            return False, f"path {path} is matched by {what}"
    return True, f"every path with up to {max_vertices} scattering vertices is in exactly one class"


__all__ = ["ALPHABET", "LETTER", "LECTURE_CLASSES", "PathClass", "PathRegexError", "parse",
           "reverse", "compile_class", "compile_classes", "JoinedClass", "compile_joined",
           "is_partition", "enumerate_paths"]
