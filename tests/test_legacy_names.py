"""The student contract's module names from before the layout of docs/architecture.md.

Submissions written against the old flat layout import ``pathtracer.geometry``,
``pathtracer.shading``, ``pathtracer.vec`` ... (autograder/contract.py, tests/bugzoo). Each old
name is the moved module itself, not a copy: patching one patches the other, as graders'
mutants and students' monkeypatches expect.
"""
from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

#: Old module name -> its home since the layout.
MOVED = {
    "pathtracer.vec": "pathtracer.core.vec",
    "pathtracer.rng": "pathtracer.core.rng",
    "pathtracer.sampling": "pathtracer.core.sampling",
    "pathtracer.geometry": "pathtracer.shapes.intersect",
    "pathtracer.shading": "pathtracer.bsdfs.shading",
    "pathtracer.camera": "pathtracer.sensors.perspective",
    "pathtracer.camera_connection": "pathtracer.sensors.importance",
}


@pytest.mark.parametrize("old, new", sorted(MOVED.items()))
def test_old_name_is_the_moved_module(old, new):
    assert importlib.import_module(old) is importlib.import_module(new)


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_name_imports_first_in_a_fresh_interpreter(old):
    # Imported before anything else of the tracer (a submission's first line), and by
    # `from ... import` of a name the contract documents.
    name = {"pathtracer.vec": "dot", "pathtracer.rng": "RandomStream",
            "pathtracer.sampling": "power_heuristic", "pathtracer.geometry": "spawn_ray",
            "pathtracer.shading": "eval_bsdf", "pathtracer.camera": "Rays",
            "pathtracer.camera_connection": "connect_to_camera"}[old]
    code = f"from {old} import {name}; import {old} as m; print(m.__name__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == MOVED[old]


def test_packages_that_replaced_modules_keep_the_contract_names():
    from pathtracer import emitters, media
    for name in ("hit_emitter", "emitted_radiance", "sample_emitter", "pdf_emitter_direction",
                 "EmitterSample", "shadowed"):
        assert callable(getattr(emitters, name)), name
    for name in ("phase_sample", "null_event", "sample_free_flight", "shadow_transmittance"):
        assert callable(getattr(media, name)), name
