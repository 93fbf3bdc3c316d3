"""The layout's rules, checked on the source (docs/architecture.md).

* No import cycle among the project's modules, counting imports inside functions and the
  package ``__init__`` that importing a submodule executes first.
* An import inside a function only of a heavy optional dependency (Mitsuba, Dr.Jit,
  matplotlib, Dask), directly or through a module of ours that imports one at its top,
  which keeps it out of start-up; or in a module that docs/architecture.md's section
  "Deferred imports" names with the reason.
* No module over 600 lines, except those docs/architecture.md names with the reason.
* The house's figures (docs/architecture.md, "Size rules"): few modules loose at each package's
  root, no function over 120 lines, no function of the harness or the grader with more than
  10 parameters, one p-value formatter.
"""
from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("pathtracer", "mitsuba_refs", "autograder", "experiments")
#: What an import inside a function may name: heavy, optional, and so kept out of start-up.
DEFERRABLE = ("mitsuba", "drjit", "matplotlib", "dask", "distributed")
MAX_LINES = 600
#: Modules (``__init__.py`` aside) a package may hold loose at its root; the rest live in
#: folders that say what they are.
MAX_ROOT_MODULES = {"mitsuba_refs": 6, "autograder": 10, "pathtracer": 4}
MAX_FUNCTION_LINES = 120
#: Parameters (``self`` / ``cls`` aside) of a function of the harness or the grader: more
#: travel as one settings value.
MAX_PARAMETERS = 10


def _modules() -> dict[str, Path]:
    found = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


MODULES = _modules()


def _is_package(module: str) -> bool:
    return MODULES[module].name == "__init__.py"


def _absolute(module: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if _is_package(module) else module.split(".")[:-1]
    base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _targets(module: str, node) -> list[str]:
    """The project modules an import statement executes (the named ones and their packages)."""
    if isinstance(node, ast.Import):
        named = [alias.name for alias in node.names]
    else:
        base = _absolute(module, node)
        named = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base
                 for alias in node.names]
    out = set()
    for name in named:
        name = _ours(name)
        while name:             # importing a.b.c runs a/__init__ and a/b/__init__ first
            out.add(name)
            name = name.rpartition(".")[0]
    return sorted(t for t in out if t in MODULES)


@functools.cache
def _imports(module: str) -> tuple:
    """``(node, inside_function)`` for every import statement of ``module`` (parsed once)."""
    tree = ast.parse(MODULES[module].read_text(), str(MODULES[module]))
    functions = [node for node in ast.walk(tree)
                 if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))]
    inside = {id(sub) for function in functions for sub in ast.walk(function)}
    return tuple((node, id(node) in inside) for node in ast.walk(tree)
                 if isinstance(node, (ast.Import, ast.ImportFrom)))


def import_graph() -> dict[str, set[str]]:
    """module -> the project modules it imports (a package's own submodules excluded from
    its parent's edges only where the submodule is the importer itself)."""
    graph = {}
    for module in MODULES:
        edges = set()
        for node, _ in _imports(module):
            edges.update(t for t in _targets(module, node)
                         if t != module and not module.startswith(t + "."))
        graph[module] = edges
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], [0]
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            advanced = False
            for succ in successors:
                if succ not in index:
                    index[succ] = low[succ] = counter[0]
                    counter[0] += 1
                    stack.append(succ)
                    on_stack.add(succ)
                    work.append((succ, iter(sorted(graph[succ]))))
                    advanced = True
                    break
                if succ in on_stack:
                    low[node] = min(low[node], index[succ])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_cycle_finder_sees_a_cycle_through_a_function_level_import():
    # The checker itself: a -> b at module level, b -> a inside a function.
    assert cycles({"a": {"b"}, "b": {"a"}, "c": {"a"}}) == [["a", "b"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles():
    found = cycles(import_graph())
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


def _documented(section: str) -> set[str]:
    """The modules a table of docs/architecture.md's ``section`` names (first column)."""
    text = (ROOT / "docs" / "architecture.md").read_text()
    body = text.split(f"## {section}", 1)[1] if f"## {section}" in text else ""
    body = body.split("\n## ", 1)[0]
    return set(re.findall(r"^\| `([\w/]+\.py)` \|", body, flags=re.M))


def _ours(name: str) -> str:
    """The module of ours that importing ``name`` runs ("" if none): ``a.b.f`` is ``a.b``."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name


def _top_level_names(module: str) -> set[str]:
    """Every name the module-level imports of ``module`` import (``from a import f``: a, a.f)."""
    names = set()
    for node, inside in _imports(module):
        if inside:
            continue
        named = [a.name for a in node.names] if isinstance(node, ast.Import) else [_absolute(module, node)]
        if isinstance(node, ast.ImportFrom):
            named += [f"{named[0]}.{a.name}" for a in node.names]
        names.update(named)
    return names


@functools.cache
def _heavy_modules() -> frozenset[str]:
    """Our modules whose top-level imports reach a heavy dependency, as a fixed point over the
    whole graph: each module visited once a round (following every import path afresh is
    exponential in the graph's depth, and once took 20 minutes of CI)."""
    names = {module: _top_level_names(module) for module in MODULES}
    heavy = {m for m, named in names.items() if any(n.split(".")[0] in DEFERRABLE for n in named)}
    while True:
        grown = heavy | {m for m, named in names.items() if any(_ours(n) in heavy for n in named)}
        if grown == heavy:
            return frozenset(heavy)
        heavy = grown


def _heavy(name: str) -> bool:
    """Whether importing ``name`` loads a heavy optional dependency: it is one, or a module of
    ours whose top-level imports (followed through our modules) reach one."""
    return name.split(".")[0] in DEFERRABLE or _ours(name) in _heavy_modules()


def test_heavy_follows_our_modules():
    assert _heavy("mitsuba") and _heavy("matplotlib.pyplot")
    assert not _heavy("numpy") and not _heavy("pathtracer.core.vec")


def test_imports_inside_functions_only_defer_heavy_optional_dependencies():
    allowed = _documented("Deferred imports")
    offenders = []
    for module in MODULES:
        if MODULES[module].relative_to(ROOT).as_posix() in allowed:
            continue
        for node, inside in _imports(module):
            if not inside:
                continue
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else [node.module or ""]
            if isinstance(node, ast.ImportFrom) and node.level:
                names = [_absolute(module, node)]
            if isinstance(node, ast.ImportFrom):
                names = [f"{names[0]}.{a.name}" if f"{names[0]}.{a.name}" in MODULES else names[0]
                         for a in node.names]
            if not all(_heavy(name) for name in names):
                offenders.append(f"{MODULES[module].relative_to(ROOT)}:{node.lineno}: {', '.join(names)}")
    assert not offenders, "imports inside functions:\n" + "\n".join(offenders)


def test_modules_are_short_or_say_why():
    allowed = _documented("Longer modules")
    long = []
    for path in MODULES.values():
        relative = path.relative_to(ROOT).as_posix()
        lines = len(path.read_text().splitlines())
        if lines > MAX_LINES and relative not in allowed:
            long.append(f"{relative}: {lines} lines")
    assert not long, (f"modules over {MAX_LINES} lines (split them, or say why in docs/architecture.md): "
                      + "; ".join(long))


def test_documented_exceptions_are_still_long():
    # An exception that no longer applies is stale documentation.
    stale = [relative for relative in _documented("Longer modules")
             if len((ROOT / relative).read_text().splitlines()) <= MAX_LINES]
    assert not stale, f"docs/architecture.md lists modules that are no longer long: {stale}"


def test_documented_deferrals_still_defer():
    stale = []
    for relative in _documented("Deferred imports"):
        module = ".".join(Path(relative).with_suffix("").parts)
        if not any(inside for _, inside in _imports(module)):
            stale.append(relative)
    assert not stale, f"docs/architecture.md lists modules without imports inside functions: {stale}"


def _functions():
    """``(path, node)`` of every function and method of the packages."""
    for path in MODULES.values():
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield path.relative_to(ROOT).as_posix(), node


def _parameters(node) -> int:
    args = node.args
    named = [*args.posonlyargs, *args.args, *args.kwonlyargs]
    count = len(named) + bool(args.vararg) + bool(args.kwarg)
    return count - bool(named and named[0].arg in ("self", "cls"))


def test_few_modules_loose_at_each_root():
    crowded = []
    for package, most in MAX_ROOT_MODULES.items():
        loose = sorted(p.name for p in (ROOT / package).glob("*.py") if p.name != "__init__.py")
        if len(loose) > most:
            crowded.append(f"{package}/: {len(loose)} > {most} ({', '.join(loose)})")
    assert not crowded, "packages with too many root modules: " + "; ".join(crowded)


def test_no_function_over_120_lines():
    long = [f"{path}:{node.lineno} {node.name} ({node.end_lineno - node.lineno + 1} lines)"
            for path, node in _functions() if node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES]
    assert not long, "functions over 120 lines: " + "; ".join(long)


def test_harness_and_grader_functions_take_at_most_10_parameters():
    many = [f"{path}:{node.lineno} {node.name} ({_parameters(node)})" for path, node in _functions()
            if path.split("/")[0] in ("mitsuba_refs", "autograder") and _parameters(node) > MAX_PARAMETERS]
    assert not many, "functions with more than 10 parameters (pass a settings value): " + "; ".join(many)


def test_one_p_value_formatter():
    # A p-value printed in two styles reads as two different numbers; every verdict line,
    # JSON record and report asks mitsuba_refs/report for its digits.
    pattern = re.compile(r"def \w*(fmt|format)_p(value)?\b")
    homes = [path.relative_to(ROOT).as_posix() for path in MODULES.values()
             if pattern.search(path.read_text())]
    assert len(homes) == 1 and homes[0].startswith("mitsuba_refs/report/"), homes
