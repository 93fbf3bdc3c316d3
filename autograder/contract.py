"""The student's contract: what an implementation provides and how ``--impl`` finds it.

An *implementation* is a Python module or package (a dotted name, a ``.py`` file or a
package directory) that exposes

``INTEGRATORS``
    a dict ``name -> class``; every class subclasses :class:`pathtracer.Integrator`, has
    the class attribute ``name`` and implements ::

        def radiance(self, scene, rays, rng) -> np.ndarray:   # shape (len(rays), 3), float

    ``scene`` is a loaded :class:`pathtracer.scene.types.Scene`, ``rays`` a
    :class:`pathtracer.camera.Rays` batch of camera rays (``o``, ``d``, ``tmax``) and ``rng`` a
    :class:`pathtracer.rng.RandomStream` with one independent stream per ray (``next_1d()``,
    ``next_2d()``, ``subset(rows)``, ``branch(copies)``). The result is *one* Monte Carlo
    sample of the radiance arriving along each ray: finite, non-negative, float.
    The constructor takes the options of :class:`pathtracer.Integrator` (``max_depth``,
    ``rr_depth``, ...), so a subclass normally only writes ``radiance``.

    The base class also holds the batch bookkeeping, so that ``radiance`` contains only the
    lecture's steps: ``self.camera_paths(scene, rays, rng)`` starts a
    :class:`pathtracer.integrators.wavefront.Paths` (every ray's result row, throughput
    ``beta``, ``eta``, random stream ``rng`` and hit; ``declare`` adds an integrator's own
    arrays), ``paths.keep(mask)`` ends the other paths with all their arrays,
    ``paths.scatter(wo, weight, eta)`` and ``paths.next_hit(scene)`` continue them,
    ``paths.add_radiance(value)`` adds to the result, and ``self.emission``,
    ``self.sample_direct`` (a shadow ray) and ``self.russian_roulette`` are shared steps.
    Their use is optional: a ``radiance`` that keeps its own arrays with the lower-level helpers
    (``trace``, ``spawn``, ``subset_hit`` of :mod:`pathtracer.integrators.base`,
    ``rng.subset``/``rng.branch``) is graded the same way.

    Without ``INTEGRATORS`` the module and, for a package, its direct submodules are searched
    for :class:`~pathtracer.Integrator` subclasses; each one's ``name`` is its key.

A light tracer (the ``light-tracing`` assignment) is a class with ``splats = True`` that
    implements ``splat(self, scene, rng) -> (pixel, value)`` instead of ``radiance``: one light
    path per random stream of ``rng``, splats as a 1-D integer array of flat pixel indices
    (row * W + column, inside the film) and an ``(m, 3)`` float array of finite, non-negative
    values; the render driver adds them to the film as independent replicas. Its camera
    connection (``connect_to_camera``, ``camera_importance`` of
    :mod:`pathtracer.camera_connection`) is the student's too: the runtime's are stubs.

``camera_rays`` (optional)
    ``camera_rays(camera, pixel, u_film) -> Rays``, Mitsuba's perspective camera, with the
    signature of :func:`pathtracer.camera.camera_rays`. Graded by the camera test only; the
    integrator tests always use the reference camera so that one mistake costs points once.

The project's own integrators follow the same contract: :mod:`autograder.solution` is the
reference solution (``pathtracer.integrators.INTEGRATORS`` plus
``pathtracer.camera.camera_rays``) and is what ``--impl`` grades by default; the student
skeleton (:mod:`autograder.skeleton`) is generated from it.

What a submission may import: the student runtime (:mod:`autograder.isolation.runtime`), i.e. the
tracer's building blocks with the integrators and the camera as stubs, NumPy and SciPy. The
grader reads a submission's source before running it and refuses it, with zero points and a
message saying why (:func:`refusal`), when it imports the reference solution, the grader or
the references (``pathtracer.integrators.<algorithm>``, ``INTEGRATORS`` and the reference
classes, ``pathtracer.camera.camera_rays``, ``autograder``, ``mitsuba_refs``, Mitsuba).
The runtime makes those imports useless anyway; the refusal makes the message clear.
"""
from __future__ import annotations

import ast
import os
from pathlib import Path

#: What ``--impl`` grades when it is not given.
DEFAULT_IMPLEMENTATION = "autograder.solution"

#: Modules of the reference solution and of the grader a submission must not import.
SOLUTION_MODULES = tuple(f"pathtracer.integrators.{name}" for name in (
    "path", "path_bsdf", "path_nee", "direct", "recursive", "smallpt", "pathclass", "light",
    # The volumetric tracers render surfaces too (MIS path tracing in vacuum).
    "volpath", "volpath_phase", "bdpt"))
GRADER_PACKAGES = ("autograder", "mitsuba_refs", "mitsuba", "drjit")
#: Names that are the reference solution wherever they are imported from.
SOLUTION_NAMES = {
    "pathtracer": {"INTEGRATORS", "make_integrator"},
    "pathtracer.integrators": {"INTEGRATORS", "make_integrator", "PathIntegrator",
                               "PathBSDFIntegrator", "PathNEEIntegrator", "DirectIntegrator",
                               "RecursiveIntegrator", "SmallptIntegrator", "LightIntegrator",
                               "BDPTIntegrator", "path",
                               "path_bsdf", "path_nee", "direct", "recursive", "smallpt",
                               "pathclass", "light", "VolPathIntegrator",
                               "VolPathPhaseIntegrator", "volpath", "volpath_phase", "bdpt"},
    "pathtracer.camera": {"camera_rays"},
    "pathtracer.camera_connection": {"connect_to_camera", "camera_importance", "pdf_camera"},
    "pathtracer.sensors.perspective": {"camera_rays"},
    "pathtracer.sensors.importance": {"connect_to_camera", "camera_importance", "pdf_camera"},
}
#: Most source a submission may have (files, bytes) before the grader stops reading.
MAX_FILES, MAX_BYTES = 200, 4 << 20


def _forbidden(module: str) -> bool:
    return (module in SOLUTION_MODULES or module.startswith(tuple(m + "." for m in SOLUTION_MODULES))
            or module.split(".")[0] in GRADER_PACKAGES)


def reference_imports(source: str, filename: str = "<submission>") -> list:
    """Lines of ``source`` that import the reference solution or the grader: ``[(line, text)]``."""
    found = []
    for node in ast.walk(ast.parse(source, filename)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if _forbidden(alias.name):
                    found.append((node.lineno, f"import {alias.name}"))
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = {alias.name for alias in node.names}
            bad = names & SOLUTION_NAMES.get(node.module, set())
            if _forbidden(node.module) or bad or "*" in names and node.module in SOLUTION_NAMES:
                what = ", ".join(sorted(bad or names))
                found.append((node.lineno, f"from {node.module} import {what}"))
        elif isinstance(node, ast.Call) and getattr(node.func, "id", None) == "__import__" \
                and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str) and _forbidden(node.args[0].value):
            found.append((node.lineno, f"__import__({node.args[0].value!r})"))
    return found


def source_files(impl: str) -> list:
    """The Python files of a submission (a ``.py`` file or a package folder)."""
    path = Path(impl)
    files = sorted(path.rglob("*.py")) if path.is_dir() else [path]
    return files[:MAX_FILES]


def refusal(impl: str) -> str:
    """Why the grader refuses to grade ``impl`` ("" when it does not).

    A submission that imports the reference solution or the grader, or whose source cannot
    be read or parsed, is refused.
    """
    problems, total = [], 0
    for file in source_files(impl):
        try:
            data = file.read_bytes()
        except OSError as error:
            return f"cannot read {file.name}: {error.strerror}"
        total += len(data)
        if total > MAX_BYTES:
            return f"the submission's Python source exceeds {MAX_BYTES >> 20} MB"
        name = os.path.relpath(file, impl) if os.path.isdir(impl) else file.name
        try:
            found = reference_imports(data.decode("utf-8", "replace"), name)
        except (SyntaxError, ValueError) as error:
            return f"{name} is not valid Python: {error}"
        problems += [f"{name}, line {line}: {text}" for line, text in found]
    if not problems:
        return ""
    return ("your submission imports the reference solution or the grader, which submissions "
            "must not use; write the integrators yourself (the grader's copy of pathtracer has "
            "them as stubs):\n  " + "\n  ".join(problems[:10]))
