"""The student contract's module names of the flat layout, each the moved module itself.

Submissions import ``pathtracer.vec``, ``pathtracer.geometry``, ``pathtracer.camera`` ...
(autograder/contract.py, tests/bugzoo). Importing this module (``pathtracer/__init__.py``
does) enters every old name in ``sys.modules`` as the module that now holds the code, not a
copy: ``from pathtracer.vec import dot`` works as a submission's first line, and patching
either name patches both, as graders' mutants and students' monkeypatches expect.
"""
import sys

from .bsdfs import shading
from .core import rng, sampling, vec
from .sensors import importance, perspective
from .shapes import intersect

#: Old name (under ``pathtracer``) -> the module it is.
MOVED = {"vec": vec, "rng": rng, "sampling": sampling, "geometry": intersect,
         "shading": shading, "camera": perspective, "camera_connection": importance}

_package = sys.modules[__package__]
for _old, _module in MOVED.items():
    sys.modules[f"{__package__}.{_old}"] = _module
    setattr(_package, _old, _module)   # as importing a submodule sets it on its package
