"""Generate the student skeleton from the reference solution.

``python -m autograder.skeleton OUT_DIR [--assignment NAME]`` writes a package
``OUT_DIR/student/`` with the modules of one assignment (``ASSIGNMENT_MODULES``):

* one module per integrator, copied from ``pathtracer/integrators/`` with every
  ``radiance`` body (or every body of the methods ``STUBS`` names for it) replaced by its
  docstring and ``raise NotImplementedError("<slide of the lecture>")``; module docstrings
  (the slide's pseudocode) and helper methods such as ``__init__``/``options`` are kept;
* ``camera.py`` with ``camera_rays`` stubbed the same way;
* ``__init__.py`` exposing ``INTEGRATORS`` and ``camera_rays`` (the contract of
  :mod:`autograder.contract`).

Relative imports become absolute (``from pathtracer.shading import ...``), so the skeleton
imports cleanly against the installed ``pathtracer`` and grades as zero; an import of another
module of the same skeleton stays relative (``volpath`` builds on the student's own
``volpath_phase``). The tracer's registrations (``@register("integrator", ...)``) are left out:
the skeleton's ``INTEGRATORS`` lists its classes.
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

#: Module -> (function(s) to stub: a name or a tuple of names, lecture slide it implements).
STUBS = {
    "integrators/path_bsdf.py": ("radiance", "slide 'Path Tracing': L = Le + f_r L cos / p"),
    "integrators/path_nee.py": ("radiance", "slides 'Path Tracing with Shadow Rays' and "
                                "'Path Tracing Algorithm'"),
    "integrators/path.py": ("radiance", "slide 'Path Tracing Algorithm' with the advice 'use "
                            "MIS at least for direct illumination'"),
    "integrators/direct.py": ("radiance", "slide 'Direct Illumination'"),
    "integrators/recursive.py": ("radiance", "slide 'Monte Carlo Ray Tracing Algorithm'"),
    "integrators/smallpt.py": ("radiance", "slide 'Path Tracing on 99 Lines of C++'"),
    "sensors/perspective.py": ("camera_rays", "slide 'Ray Tracing' (primary rays of a perspective camera)"),
    # The segment loop, the scattering step in a medium and the surface step with medium
    # tracking; volpath inherits the loop and the surface step's bounce from volpath_phase.
    "integrators/volpath_phase.py": (("radiance", "in_medium", "on_surface", "bounce"),
                                     "volumetric path tracing: free-flight distance sampling, "
                                     "phase-function sampling, medium boundaries"),
    "integrators/volpath.py": (("in_medium", "on_surface", "shadow_ray"),
                               "volumetric path tracing with shadow rays: transmittance along "
                               "shadow rays and MIS"),
    "integrators/light.py": ("splat", "slide 'Light Tracing': paths from the lights, importance "
                             "transport (no 1/eta^2), every vertex connected to the camera"),
    "sensors/importance.py": (("connect_to_camera", "camera_importance"),
                             "slide 'Light Tracing': the pixel a point projects to and the "
                             "camera's importance We = 1 / (A cos^3)"),
}

#: The modules of each assignment's skeleton (keys of ``STUBS``; the order of ``INTEGRATORS``).
ASSIGNMENT_MODULES = {
    "path-tracing": ("integrators/path.py", "integrators/path_bsdf.py", "integrators/path_nee.py",
                     "integrators/recursive.py", "integrators/smallpt.py", "integrators/direct.py",
                     "sensors/perspective.py"),
    "media": ("integrators/volpath_phase.py", "integrators/volpath.py"),
    "light-tracing": ("integrators/light.py", "sensors/importance.py"),
}

#: A module's file name in the student's package where it differs from the tracer's: the
#: contract's names, which submissions already use (``from .camera import camera_rays``).
SKELETON_NAMES = {"sensors/perspective.py": "camera.py", "sensors/importance.py": "camera_connection.py"}


def skeleton_name(relative: str) -> str:
    """The file name of the tracer's module ``relative`` in the student's package."""
    return SKELETON_NAMES.get(relative, Path(relative).name)

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
    "media": """A path in a medium is a sequence of segments, each ending where the next event is sampled: a
scattering point in the medium or the next surface. pathtracer/media.py has the building blocks
(sample_free_flight, phase_sample / phase_eval, next_medium, null_event, shadow_transmittance);
integrators/volume.py keeps the bookkeeping: the per-path arrays (a Paths of
integrators/wavefront.py, made by self.start, with the ray of each path's next segment, its
medium, channel, depth ...), random numbers per segment (self.uniform), roulette
(self.survivors) and tracing (self.trace_segment). volpath_phase:

    def radiance(self, scene, rays, rng):
        paths = self.start(scene, rays, rng)             # camera rays, in the sensor's medium
        for segment in range(MAX_SEGMENTS):
            # roulette and the depth limit           paths.keep(self.survivors(...))
            # the next surface                       hit = self.trace_segment(scene, paths)
            # free flight: scatter before it?        flight = sample_free_flight(...)
            #   throughput x T / pdf                 paths.beta *= flight.weight
            # scattered: phase-function sample      self.in_medium(...)
            # else: emission, BSDF sample and the    self.on_surface(...) -> self.bounce(...)
            #   medium on the other side (null
            #   boundaries too)                      next_medium(...)
            # the paths that go on                   paths.keep(goes_on)
        return paths.L                               # in_medium / on_surface add to it with
                                                     # add_radiance(value, rows)

volpath adds a shadow ray where a path scatters (in the medium and on smooth surfaces): the light
sample times the transmittance to the light (shadow_transmittance), MIS-weighted against the
phase function / BSDF sample, and weights emission found by that sample accordingly.
""",
    "light-tracing": """A light tracer splats: pathtracer.render traces W H spp light paths (as independent
replicas, for the variance) and adds each splat to its pixel, so you write what one batch of
light paths does, and the camera's side of the connection:

    def splat(self, scene, rng):                        # integrators/light.py
        # points on the lights seen directly        self.visible_emitters(scene, rng)
        # a ray leaving a light                     sample_emitter_ray(...); Paths(...)
        while paths:
            # light paths that escaped end          paths.keep(paths.hit.valid)
            # connect the vertex to the camera      self.connect(scene, hit, wi, beta)
            # the next direction (importance:       sample_bsdf(..., adjoint=True)
            #   the adjoint BSDF, no 1/eta^2)       paths.scatter(...)
            # Russian roulette, the next hit        self.russian_roulette(paths); paths.next_hit
        return pixels, values                       # (m,) int, (m, 3): one row per splat

    def connect_to_camera(camera, p):               # camera_connection.py
        # the pixel p projects to (-1 outside the film), the direction and distance to the
        # pinhole, and its importance We / d^2 with camera_importance (We = 1 / (A cos^3))
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
    {classes},)}}

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
        module = Path(skeleton_name(relative)).stem
        if module == "camera":
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


def absolute_imports(source: str, package: str, siblings=()) -> str:
    """``from ..x import`` / ``from .x import`` -> ``from pathtracer[.pkg].x import``, except
    ``from .x import`` of a module ``x`` in ``siblings`` (another module of the skeleton)."""
    def repl(match):
        dots, rest = match.group(1), match.group(2)
        if dots == "." and rest in siblings:
            return match.group(0)
        parts = package.split(".")
        base = parts[:len(parts) - (len(dots) - 1)]
        target = ".".join(base + ([rest] if rest else []))
        return f"from {target} import"
    return re.sub(r"^from (\.+)([\w.]*) import", repl, source, flags=re.M)


def sibling_imports(source: str, assignment: str) -> str:
    """``from pathtracer.<m> import`` -> ``from .<m> import`` for the assignment's other modules
    in other packages of the tracer (light.py's ``..camera_connection``): the skeleton is one
    flat package, and a student's module must call the student's own functions."""
    for relative in ASSIGNMENT_MODULES[assignment]:
        dotted = "pathtracer." + relative[:-len(".py")].replace("/", ".")
        source = re.sub(rf"^from {re.escape(dotted)} import", f"from .{Path(skeleton_name(relative)).stem} import",
                        source, flags=re.M)
    return source


def unregistered(source: str) -> str:
    """``source`` without its registrations (the ``@register(...)`` decorators and the import
    of ``register``): a skeleton's classes are the student's, listed by its own
    ``INTEGRATORS``; registering them under the tracer's names would clash with the tracer's."""
    tree = ast.parse(source)
    drop = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ClassDef):
            for decorator in node.decorator_list:
                if isinstance(decorator, ast.Call) and getattr(decorator.func, "id", None) == "register":
                    drop.update(range(decorator.lineno - 1, decorator.end_lineno))
        elif isinstance(node, ast.ImportFrom) and [alias.name for alias in node.names] == ["register"]:
            drop.update(range(node.lineno - 1, node.end_lineno))
    return "".join(line for number, line in enumerate(source.splitlines(keepends=True))
                   if number not in drop)


def stub_names(name) -> tuple:
    """The function names of a ``STUBS`` entry (one name or a tuple of names)."""
    return (name,) if isinstance(name, str) else tuple(name)


def stub_source(source: str, name, slide: str) -> str:
    """Replace the body of every function or method ``name`` (or of each of a tuple of
    names) by docstring + raise."""
    names = stub_names(name)
    tree = ast.parse(source)
    lines = source.splitlines(keepends=True)
    targets = [node for node in ast.walk(tree)
               if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name in names]
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
        message = f"{node.name}: implement the lecture's {slide}".replace('"', "'")
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
    siblings = {Path(skeleton_name(relative)).stem for relative in ASSIGNMENT_MODULES[assignment]}
    for relative in ASSIGNMENT_MODULES[assignment]:
        name, slide = STUBS[relative]
        source = (SOURCE / relative).read_text()
        module_package = "pathtracer." + ".".join(Path(relative).parent.parts)
        module_package = module_package.rstrip(".")
        source = unregistered(sibling_imports(absolute_imports(source, module_package, siblings),
                                              assignment))
        if stubs:
            source = stub_source(source, name, slide)
        header = (f"# Generated by `python -m autograder.skeleton` from pathtracer/{relative}.\n"
                  f"# Implement {', '.join(stub_names(name))} (the lecture's {slide}).\n")
        (package / skeleton_name(relative)).write_text(header + source)
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
