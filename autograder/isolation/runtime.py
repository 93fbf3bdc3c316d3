"""The student runtime: the only code of this project a submission can import.

A folder with

``pathtracer/``    the tracer the students build on (scenes, geometry, BSDFs, emitters,
                   sampling, the render driver), with every integrator's ``radiance`` and
                   the camera's ``camera_rays`` replaced by the skeleton's stubs
                   (:func:`autograder.skeleton.stub_source`) and the path-class integrator
                   removed: the reference solution is not in it;
``grading_child/`` the student process's code (:mod:`autograder.sandbox`).

The *solution* flavour keeps the reference integrators and camera and adds a package
``solution`` in the student contract; it serves the reference solution itself and the
instructors' bug zoo and correct alternatives, which are built on it. Never give it to a
student's submission.

Everything in the folder is world-readable (the student user runs from it); what must stay
private (references, the solution, the grader, results) is elsewhere.
"""
from __future__ import annotations

import argparse
import ast
import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pathtracer

from ..skeleton import STUBS, stub_source

PATHTRACER = Path(pathtracer.__file__).resolve().parent
SANDBOX = Path(__file__).resolve().parents[1] / "sandbox"
SANDBOX_FILES = ("__init__.py", "child.py", "wire.py", "seccomp.py", "syscalls.py", "landlock.py",
                 "privileges.py")
#: Solution code that is not a stub target of the skeleton: left out of the student runtime.
PRIVATE_MODULES = ("integrators/pathclass.py", "cli.py")
#: Integrators the course does not grade (yet): the registry imports them, so the student
#: runtime keeps each class, with its name and options, but not its algorithm.
UNGRADED_MODULES = ("integrators/bdpt.py",)
FLAVOURS = ("student", "solution")

SOLUTION_INIT = '''"""The reference solution in the student contract (solution runtime only)."""
from pathtracer.sensors.perspective import camera_rays
from pathtracer.integrators import INTEGRATORS

__all__ = ["INTEGRATORS", "camera_rays"]
'''

BOOT = ("import sys; sys.path[0] = sys.argv[1]; "
        "from grading_child.child import main; main(sys.argv[1], sys.argv[2])")


def build(dest, flavour: str = "student", public: bool = True) -> Path:
    """Write a runtime into the empty or new folder ``dest``; returns its path.

    ``public``: readable by every user (a child running as the student user needs that);
    otherwise only by its owner (a child running as the grader's own user).
    """
    if flavour not in FLAVOURS:
        raise ValueError(f"flavour must be one of {FLAVOURS}, got {flavour!r}")
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    tracer = dest / "pathtracer"
    shutil.copytree(PATHTRACER, tracer, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    if flavour == "student":
        for relative, (name, slide) in STUBS.items():
            module = tracer / relative
            module.write_text(stub_source(module.read_text(), name, slide))
        for relative in PRIVATE_MODULES:
            (tracer / relative).unlink()
        for relative in UNGRADED_MODULES:
            module = tracer / relative
            module.write_text(ungraded_source(module.read_text()))
    else:
        (dest / "solution").mkdir()
        (dest / "solution" / "__init__.py").write_text(SOLUTION_INIT)
    (dest / "grading_child").mkdir()
    for name in SANDBOX_FILES:
        shutil.copy(SANDBOX / name, dest / "grading_child" / name)
    _world_readable(dest)
    if not public:
        os.chmod(dest, 0o700)
    return dest


#: The base classes an ungraded integrator's stub keeps, and the method its stub refuses.
STUB_METHODS = {"CameraIntegrator": "radiance(self, scene, rays, rng)",
                "SplattingIntegrator": "splat(self, scene, rng, *pixels)"}


def ungraded_source(source: str) -> str:
    """A module with each integrator class of ``source`` reduced to a stub that says why.

    The class keeps its ``name``, its registration (the registry is built from it) and its
    kind (camera or splatting integrator); everything else of the module (the algorithm, its
    helpers) is left out.
    """
    tree = ast.parse(source)
    classes = [node for node in tree.body if isinstance(node, ast.ClassDef)]
    lines, kinds = [], set()
    for node in classes:
        name = next((stmt.value.value for stmt in node.body if isinstance(stmt, ast.Assign)
                     and any(getattr(t, "id", None) == "name" for t in stmt.targets)
                     and isinstance(stmt.value, ast.Constant)), None)
        registrations = [ast.get_source_segment(source, decorator) for decorator in node.decorator_list
                         if isinstance(decorator, ast.Call) and getattr(decorator.func, "id", None) == "register"]
        kind = next((base.id for base in node.bases if getattr(base, "id", None) in STUB_METHODS), None)
        if not isinstance(name, str) or not registrations or kind is None:   # not a registered integrator
            continue
        kinds.add(kind)
        lines += [""] + [f"@{registration}" for registration in registrations]
        lines += [f"class {node.name}({kind}):", f"    name = {name!r}", "",
                  f"    def {STUB_METHODS[kind]}:",
                  f"        raise NotImplementedError(\"{name}: not part of the graded course\")", ""]
    header = ['"""Not part of the student runtime: an integrator the course does not grade."""',
              "from ..scene.registry import register",
              f"from .base import {', '.join(sorted(kinds))}", ""]
    return "\n".join(header + lines)


def _world_readable(root: Path) -> None:
    os.chmod(root, 0o755)
    for folder, dirs, files in os.walk(root):
        for name in dirs:
            os.chmod(os.path.join(folder, name), 0o755)
        for name in files:
            os.chmod(os.path.join(folder, name), 0o644)


_BUILT = {}


def cached(flavour: str = "student", public: bool = True) -> Path:
    """The runtime of ``flavour`` for this process, built on first use in a temporary folder
    (removed at exit); see :func:`build` for ``public``."""
    key = (flavour, public)
    if key not in _BUILT:
        folder = tempfile.mkdtemp(prefix=f"autograder-runtime-{flavour}-")
        atexit.register(shutil.rmtree, folder, True)
        _BUILT[key] = build(folder, flavour, public)
    return _BUILT[key]


def public_solution_runtimes() -> list:
    """Solution runtimes of this process that every user can read (private to the grader)."""
    return [path for (flavour, public), path in _BUILT.items() if flavour == "solution" and public]


def main(argv=None) -> int:
    """``python -m autograder.isolation.runtime DEST [--flavour student|solution]``."""
    parser = argparse.ArgumentParser(description="write the student runtime")
    parser.add_argument("dest")
    parser.add_argument("--flavour", choices=FLAVOURS, default="student")
    args = parser.parse_args(argv)
    print(build(args.dest, args.flavour))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
