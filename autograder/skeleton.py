"""Generate the student skeleton from the reference solution.

``python -m autograder.skeleton OUT_DIR [--assignment NAME]`` writes a package
``OUT_DIR/student/`` with the modules of one assignment (``ASSIGNMENT_MODULES``):

* one module per integrator, copied from ``pathtracer/integrators/`` with every
  ``radiance`` body replaced by its docstring and
  ``raise NotImplementedError("<slide of the lecture>")``; module docstrings (the slide's
  pseudocode) and helper methods such as ``__init__``/``options`` are kept;
* ``camera.py`` with ``camera_rays`` stubbed the same way;
* ``__init__.py`` exposing ``INTEGRATORS`` and ``camera_rays`` (the contract of
  :mod:`autograder.contract`).

Relative imports become absolute (``from pathtracer.shading import ...``), so the skeleton
imports cleanly against the installed ``pathtracer`` and grades as zero.
"""
from __future__ import annotations

import argparse
import ast
import re
import sys
import textwrap
from pathlib import Path

import pathtracer

SOURCE = Path(pathtracer.__file__).resolve().parent

#: Module -> (class or function to stub, lecture slide it implements).
STUBS = {
    "integrators/path_bsdf.py": ("radiance", "slide 'Path Tracing': L = Le + f_r L cos / p"),
    "integrators/path_nee.py": ("radiance", "slides 'Path Tracing with Shadow Rays' and "
                                "'Path Tracing Algorithm'"),
    "integrators/path.py": ("radiance", "slide 'Path Tracing Algorithm' with the advice 'use "
                            "MIS at least for direct illumination'"),
    "integrators/direct.py": ("radiance", "slide 'Direct Illumination'"),
    "integrators/recursive.py": ("radiance", "slide 'Monte Carlo Ray Tracing Algorithm'"),
    "integrators/smallpt.py": ("radiance", "slide 'Path Tracing on 99 Lines of C++'"),
    "camera.py": ("camera_rays", "slide 'Ray Tracing' (primary rays of a perspective camera)"),
}

#: The modules of each assignment's skeleton (keys of ``STUBS``; the order of ``INTEGRATORS``).
ASSIGNMENT_MODULES = {
    "path-tracing": ("integrators/path.py", "integrators/path_bsdf.py", "integrators/path_nee.py",
                     "integrators/recursive.py", "integrators/smallpt.py", "integrators/direct.py",
                     "camera.py"),
}

#: The loop each assignment's ``__init__.py`` sketches: the slide's steps, with the path-state
#: operations that implement them.
ASSIGNMENT_LOOPS = {
    "path-tracing": """A radiance traces all its rays at once; the base class keeps the bookkeeping of which paths
are still alive (pathtracer/integrators/wavefront.py), so you write only the slide's steps:

    def radiance(self, scene, rays, rng):
        paths = self.camera_paths(scene, rays, rng)     # every camera ray at its first hit
        while paths:
            # emission at the hits               paths.add_radiance(...)
            # paths that escaped or may not      paths.keep(mask)
            #   scatter again end                if not paths: break
            # direct light (a shadow ray)        self.sample_direct(scene, paths, ...)
            # the next direction                 bs = sample_bsdf(...); paths.scatter(...)
            # Russian roulette                   self.russian_roulette(paths)
            # the next hit                       paths.next_hit(scene)
        return paths.L
""",
}

INIT = '''"""Your implementation: fill in every function that raises NotImplementedError.

Grade it locally with
    pytest autograder/tests_for_students --assignment {assignment} --impl path/to/student
(from the project's source folder). Import only pathtracer's building blocks (geometry,
shading, emitters, sampling, the base class, the path state), NumPy and SciPy: a
submission that imports the reference integrators, the reference camera or the grader is
refused.

{loop}"""
from pathtracer.integrators.base import Integrator

{imports}

INTEGRATORS = {{cls.name: cls for cls in (
    {classes})}}

__all__ = {exports}
'''


def integrator_classes(source: str) -> list:
    """Names of the classes of ``source`` that register an integrator (a string ``name``)."""
    found = []
    for node in ast.parse(source).body:
        if isinstance(node, ast.ClassDef) and any(
                isinstance(stmt, ast.Assign) and isinstance(stmt.value, ast.Constant)
                and isinstance(stmt.value.value, str)
                and any(getattr(t, "id", None) == "name" for t in stmt.targets)
                for stmt in node.body):
            found.append(node.name)
    return found


def init_source(assignment: str) -> str:
    """The skeleton's ``__init__.py`` for ``assignment``: the contract's ``INTEGRATORS``
    (and ``camera_rays`` where the assignment grades the camera)."""
    imports, classes, exports = [], [], ["INTEGRATORS", "Integrator"]
    for relative in ASSIGNMENT_MODULES[assignment]:
        module = Path(relative).stem
        if relative == "camera.py":
            imports.append("from .camera import camera_rays")
            exports.append("camera_rays")
            continue
        names = integrator_classes((SOURCE / relative).read_text())
        imports += [f"from .{module} import {name}" for name in names]
        classes += names
    return INIT.format(assignment=assignment, loop=ASSIGNMENT_LOOPS[assignment],
                       imports="\n".join(sorted(imports)),
                       classes="\n    ".join(textwrap.wrap(", ".join(classes), 92)),
                       exports=repr(exports).replace("'", '"'))


def absolute_imports(source: str, package: str) -> str:
    """``from ..x import`` / ``from .x import`` -> ``from pathtracer[.pkg].x import``."""
    def repl(match):
        dots, rest = match.group(1), match.group(2)
        parts = package.split(".")
        base = parts[:len(parts) - (len(dots) - 1)]
        target = ".".join(base + ([rest] if rest else []))
        return f"from {target} import"
    return re.sub(r"^from (\.+)([\w.]*) import", repl, source, flags=re.M)


def stub_source(source: str, name: str, slide: str) -> str:
    """Replace the body of every function or method ``name`` by docstring + raise."""
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    targets = [node for node in ast.walk(tree)
               if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name == name]
    # Replace from the bottom so that line numbers above stay valid.
    for node in sorted(targets, key=lambda n: n.lineno, reverse=True):
        body = node.body
        keep_doc = (isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant)
                    and isinstance(body[0].value.value, str))
        first = body[1] if keep_doc and len(body) > 1 else body[0]
        if keep_doc and len(body) == 1:
            start = body[0].end_lineno
        else:
            start = first.lineno - 1
        indent = " " * (first.col_offset if not (keep_doc and len(body) == 1) else body[0].col_offset)
        message = f"{name}: implement the lecture's {slide}".replace('"', "'")
        stub = f'{indent}raise NotImplementedError("{message}")\n'
        lines[start:node.end_lineno] = [stub]
    return "".join(lines)


def generate(out_dir, stubs: bool = True, assignment: str = "path-tracing") -> Path:
    """Write the skeleton package ``out_dir/student`` of ``assignment``; return its path.

    ``stubs=False`` writes the reference solution itself in the student's layout, a
    stand-alone correct submission for testing the grader end to end.
    """
    package = Path(out_dir) / "student"
    package.mkdir(parents=True, exist_ok=True)
    for relative in ASSIGNMENT_MODULES[assignment]:
        name, slide = STUBS[relative]
        source = (SOURCE / relative).read_text()
        module_package = "pathtracer." + ".".join(Path(relative).parent.parts)
        module_package = module_package.rstrip(".")
        source = absolute_imports(source, module_package)
        if stubs:
            source = stub_source(source, name, slide)
        header = (f"# Generated by `python -m autograder.skeleton` from pathtracer/{relative}.\n"
                  f"# Implement {name} (the lecture's {slide}).\n")
        (package / Path(relative).name).write_text(header + source)
    (package / "__init__.py").write_text(init_source(assignment))
    return package


def main(argv=None) -> int:
    """Write the student skeleton package (command line); exit code."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", help="folder to write the package 'student' into")
    parser.add_argument("--assignment", choices=list(ASSIGNMENT_MODULES), default="path-tracing",
                        help="the assignment whose skeleton is written (default: %(default)s)")
    args = parser.parse_args(argv)
    package = generate(args.out_dir, assignment=args.assignment)
    print(f"wrote {package}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
