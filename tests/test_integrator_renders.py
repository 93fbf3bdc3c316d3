"""Every integrator renders exactly the saved images (bit for bit, for a fixed seed).

The renders in ``tests/data/integrator_renders.npz`` were made before the integrators were
rewritten around the path state (:class:`pathtracer.integrators.base.Paths`); this test proves
that the rewrite changed no random number and no float operation: each integrator with each
option that changes its control flow (``max_depth`` 0-3, ``hide_emitters``, the roulette
rules, uniform hemisphere sampling, ``recursive``'s branches, ``smallpt``'s glass split,
``direct``'s sample counts, path classes) on scenes with diffuse, mirror, glass and rough
surfaces, area, point and environment lights. Small images (12x12 or 8x8 pixels, 4-8 spp)
keep it under ~10 s.

Regenerated once since (2026-12-01), for the speed work of docs/performance.md, whose last
bits differ: parallelograms in SmallMesh (t from the rectangle, not its triangle), radiance
summed per path before it reaches L, row-wise dot products, float32 angles in the concentric
disk map (images within 4.1e-6 of the old ones, relative to their maximum; median 8e-10),
after every statistical suite had passed on the new code (written twice that day: the
second time when the disk map took theta's sine and cosine instead of those of pi/2 - theta,
which made the axes exact again).

Regenerating the file (``python tests/test_integrator_renders.py --write``) is allowed only
for an *intended* numeric change, e.g. in the shared geometry, BSDF, emitter or sampling
code, after the statistical suites (test_agreement.py, test_analytic.py, ...) have accepted
the new images; never to make a refactor of the integrators pass. Say which change it was in
the commit that rewrites the file.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.integrators.pathclass import PathClassIntegrator
from pathtracer.render.classes import render_classes

DATA = Path(__file__).resolve().parent / "data" / "integrator_renders.npz"
SEED = 7

#: Scenes of the integrator x scene matrix: glass + mirror, two lights, a point light, an
#: environment, rough conductors and plastic, and smallpt's room (glass split, roulette).
SCENES = ("cornell-caustics", "cornell-lights", "point-light", "envmap", "materials", "smallpt")
#: The camera-path surface integrators the path-state rewrite touched. ``light`` and ``bdpt``
#: (light paths, splatted) and the volumetric integrators have their own tests (tests/test_light.py,
#: tests/test_bdpt.py, tests/test_media.py).
ALL = ("direct", "path", "path_bsdf", "path_nee", "recursive", "smallpt", "pathclass")


def _cases() -> dict:
    """name -> (scene, integrator, options, (width, height), spp)."""
    cases = {}
    for scene in SCENES:
        for name in ALL:
            cases[f"{scene}/{name}"] = (scene, name, {}, (12, 12), 4)
    variants = [dict(max_depth=d) for d in (0, 1, 2, 3)] + [
        dict(hide_emitters=True), dict(roulette="constant", rr_depth=1),
        dict(roulette="off", max_depth=6), dict(hemisphere="uniform"), dict(rr_depth=1)]
    for options in variants:
        for name in ALL:
            key = ",".join(f"{k}={v}" for k, v in options.items())
            cases[f"cornell-caustics/{name}/{key}"] = ("cornell-caustics", name, options, (8, 8), 8)
    extra = {
        "recursive/branches=3,branch_depth=1": ("recursive", dict(branches=3, branch_depth=1)),
        "recursive/branches=1": ("recursive", dict(branches=1)),
        "smallpt/split_depth=4": ("smallpt", dict(split_depth=4)),
        "smallpt/split_depth=0": ("smallpt", dict(split_depth=0)),
        "direct/emitter_samples=2,bsdf_samples=3": ("direct", dict(emitter_samples=2, bsdf_samples=3)),
        "direct/emitter_samples=0": ("direct", dict(emitter_samples=0)),
        "direct/bsdf_samples=0": ("direct", dict(bsdf_samples=0)),
        "pathclass/LS+DE": ("pathclass", dict(classes="LS+DE")),
    }
    for key, (name, options) in extra.items():
        for scene in ("cornell-caustics", "cornell-lights"):
            cases[f"{scene}/{key}"] = (scene, name, options, (8, 8), 8)
    return cases


CASES = _cases()


def _render(scene, name, options, size, spp) -> np.ndarray:
    scene = load_scene(scene, resolution=size)
    options = dict(options)
    integrator = name
    if name == "pathclass":
        integrator = PathClassIntegrator(options.pop("classes", "L.*E"))
    return render(scene, integrator, spp=spp, seed=SEED, processes=1, progress=False,
                  **options).mean


def _render_classes() -> np.ndarray:
    """All classes of one pass (the path-class integrator's own render)."""
    scene = load_scene("cornell-caustics", resolution=(8, 8))
    return render_classes(scene, ["L.*E", "LDE", "LS+DE", "L.*SE"], spp=8, seed=SEED,
                          processes=1)["mean"]


def _all_renders() -> dict:
    images = {key: _render(*case) for key, case in CASES.items()}
    images["render_classes"] = _render_classes()
    return images


@pytest.fixture(scope="module")
def saved():
    with np.load(DATA) as data:
        return dict(data)


def test_every_case_is_saved(saved):
    assert set(saved) == set(CASES) | {"render_classes"}


def _group(key: str) -> str:
    """The integrator x scene matrix by scene; the option variants by integrator."""
    parts = key.split("/")
    return parts[0] if len(parts) == 2 else f"variants of {parts[1]}"


GROUPS = sorted({_group(k) for k in CASES})


@pytest.mark.parametrize("group", GROUPS)
def test_renders_are_bit_identical(saved, group):
    keys = [k for k in CASES if _group(k) == group]
    different = [k for k in keys if not np.array_equal(_render(*CASES[k]), saved[k])]
    assert not different, f"renders differ from the saved ones: {different}"


def test_render_classes_is_bit_identical(saved):
    assert np.array_equal(_render_classes(), saved["render_classes"])


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/test_integrator_renders.py --write  (see the docstring)")
    images = _all_renders()
    np.savez_compressed(DATA, **images)
    print(f"wrote {len(images)} renders to {DATA} ({DATA.stat().st_size // 1024} KB)")
