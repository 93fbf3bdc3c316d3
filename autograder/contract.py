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

    Without ``INTEGRATORS`` the module and, for a package, its direct submodules are searched
    for :class:`~pathtracer.Integrator` subclasses; each one's ``name`` is its key.

``camera_rays`` (optional)
    ``camera_rays(camera, pixel, u_film) -> Rays``, Mitsuba's perspective camera, with the
    signature of :func:`pathtracer.camera.camera_rays`. Graded by the camera test only; the
    integrator tests always use the reference camera so that one mistake costs points once.

The project's own integrators follow the same contract: :mod:`autograder.solution` is the
reference solution (``pathtracer.integrators.INTEGRATORS`` plus
``pathtracer.camera.camera_rays``) and is what ``--impl`` grades by default; the student
skeleton (:mod:`autograder.skeleton`) is generated from it.
"""
from __future__ import annotations

import importlib
import importlib.util
import inspect
import pkgutil
import sys
from dataclasses import dataclass
from pathlib import Path

#: What ``--impl`` grades when it is not given.
DEFAULT_IMPLEMENTATION = "autograder.solution"


class ImplementationError(Exception):
    """The implementation cannot be imported or does not follow the contract."""


@dataclass
class Implementation:
    """A loaded implementation: its integrator classes by name and its camera (or None)."""

    spec: str
    integrators: dict
    camera_rays: object = None


def _import_path(path: Path):
    """Import a ``.py`` file or a package directory under a private module name."""
    path = path.resolve()
    if path.is_dir():
        init = path / "__init__.py"
        if not init.exists():
            raise ImplementationError(f"{path} is a folder without __init__.py (not a package)")
        name, location, search = path.name, init, [str(path)]
    else:
        name, location, search = path.stem, path, None
    module_name = f"student_impl_{name}".replace("-", "_")
    # Absolute imports of sibling modules inside a single-file implementation keep working.
    parent = str(path.parent)
    if parent not in sys.path:
        sys.path.insert(0, parent)
    spec = importlib.util.spec_from_file_location(module_name, location,
                                                  submodule_search_locations=search)
    if spec is None or spec.loader is None:
        raise ImplementationError(f"cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[module_name] = module
    spec.loader.exec_module(module)
    return module


def import_module(spec: str):
    """The module named by ``spec``: a path (file or package folder) or a dotted module name."""
    path = Path(spec)
    if spec.endswith(".py") or path.is_dir() or path.exists():
        if not path.exists():
            raise ImplementationError(f"--impl {spec}: no such file or folder")
        return _import_path(path)
    return importlib.import_module(spec)


def _integrator_classes(module) -> dict:
    from pathtracer.integrators.base import Integrator
    found = {}
    modules = [module]
    if hasattr(module, "__path__"):
        for info in pkgutil.iter_modules(module.__path__):
            modules.append(importlib.import_module(f"{module.__name__}.{info.name}"))
    for mod in modules:
        for _, obj in inspect.getmembers(mod, inspect.isclass):
            if issubclass(obj, Integrator) and obj is not Integrator and obj.name != "base":
                found.setdefault(obj.name, obj)
    return found


def load_implementation(spec: str | None = None) -> Implementation:
    """Import an implementation and check its shape (not its correctness).

    Raises
    ------
    ImplementationError
        Import failure or a registry that breaks the contract; the message says which.
    """
    from pathtracer.integrators.base import Integrator
    spec = spec or DEFAULT_IMPLEMENTATION
    module = import_module(spec)
    integrators = getattr(module, "INTEGRATORS", None)
    if integrators is None:
        integrators = _integrator_classes(module)
    if not isinstance(integrators, dict):
        raise ImplementationError(f"{spec}: INTEGRATORS must be a dict name -> class")
    for name, cls in integrators.items():
        if not (inspect.isclass(cls) and issubclass(cls, Integrator)):
            raise ImplementationError(f"{spec}: INTEGRATORS[{name!r}] is not a subclass of "
                                      "pathtracer.Integrator")
    camera = getattr(module, "camera_rays", None)
    return Implementation(spec, dict(integrators), camera)
