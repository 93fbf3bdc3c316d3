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

Bit for bit holds where NumPy picks the same kernels: its SIMD builds of ``arccos``,
``arctan2``, ``sin``, ``exp`` ... round differently by a unit in the last place on a CPU with
AVX-512 (X86_V4) than on one with AVX2 only (the envmap's directions go through ``arctan2`` and
``arccos``). The file records the NumPy version and the kernel every floating-point ufunc loop
runs (:func:`numpy.lib.introspect.opt_func_info`); where they are the same here the renders
must be equal, elsewhere within ``ULPS`` units in the last place of each image's maximum, which
a changed random number or a dropped factor exceeds by orders of magnitude (the hash of every
built-in render, compared before and after a refactor on one machine, is then the bit-for-bit
proof). The table once held the transcendental functions alone; they report the same kernels
on an Intel Xeon with AVX-512 as on an AMD EPYC with AVX2 and still round differently there,
so the file written on the AMD machine was taken as "same kernels" on the Intel one and its 7
envmap renders failed bit for bit (they differ by at most 72 ulp of their maximum); the whole
table tells the two apart (76 loops run X86_V4 kernels on the Intel machine). Saved last on
2026-12-02 on that Intel Xeon (AVX-512, NumPy 2.4.6), from the same code as the file of
2026-12-01 (AMD EPYC, AVX2), whose renders it matches within those 72 ulp.

Regenerating the file (``python tests/test_integrator_renders.py --write``) is allowed only
for an *intended* numeric change, e.g. in the shared geometry, BSDF, emitter or sampling
code, after the statistical suites (test_agreement.py, test_analytic.py, ...) have accepted
the new images; never to make a refactor of the integrators pass. Say which change it was in
the commit that rewrites the file.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.lib.introspect import opt_func_info

from pathtracer import load_scene, render
from pathtracer.integrators.pathclass import PathClassIntegrator
from pathtracer.render.classes import render_classes

DATA = Path(__file__).resolve().parent / "data" / "integrator_renders.npz"
SEED = 7
#: The loops whose kernels are recorded: every floating-point one (the kernel names of a few
#: functions do not tell the CPUs apart, see the docstring).
FLOAT_LOOPS = "^(d|f|dd|ff|ddd|fff)$"  # argmax-like, unary and binary; float64 and float32
#: Where the kernels differ: the tolerance, in units in the last place of the image maximum.
ULPS = 1024

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


def environment() -> str:
    """NumPy's version and the kernel each floating-point ufunc loop runs here (JSON)."""
    kernels = opt_func_info(signature=FLOAT_LOOPS)
    current = {name: {sig: entry["current"] for sig, entry in sorted(sigs.items())}
               for name, sigs in sorted(kernels.items())}
    return json.dumps({"numpy": np.__version__, "kernels": current}, sort_keys=True)


@pytest.fixture(scope="module")
def saved():
    with np.load(DATA) as data:
        images = dict(data)
    images.pop("environment", None)
    return images


@pytest.fixture(scope="module")
def same_kernels():
    """Whether this machine runs the NumPy kernels the file was written with."""
    with np.load(DATA) as data:
        written = str(data["environment"]) if "environment" in data else None
    return written == environment()


def _same(image, saved_image, bitwise: bool) -> bool:
    if bitwise:
        return np.array_equal(image, saved_image)
    scale = float(np.max(np.abs(saved_image))) if saved_image.size else 0.0
    return image.shape == saved_image.shape and bool(
        np.all(np.abs(image - saved_image) <= ULPS * np.finfo(float).eps * max(scale, np.finfo(float).tiny)))


def test_every_case_is_saved(saved):
    assert set(saved) == set(CASES) | {"render_classes"}


def test_the_file_records_its_environment():
    with np.load(DATA) as data:
        assert "environment" in data
        assert set(json.loads(str(data["environment"]))) == {"numpy", "kernels"}


def test_tolerance_sees_a_one_percent_error():
    # The fallback comparison still refuses any error a refactor could make visible.
    image = np.linspace(0.0, 2.0, 12).reshape(2, 2, 3)
    assert _same(image * (1 + 1e-14), image, bitwise=False)
    assert not _same(image * 1.01, image, bitwise=False)
    assert not _same(image * (1 + 1e-14), image, bitwise=True)


def _group(key: str) -> str:
    """The integrator x scene matrix by scene; the option variants by integrator."""
    parts = key.split("/")
    return parts[0] if len(parts) == 2 else f"variants of {parts[1]}"


GROUPS = sorted({_group(k) for k in CASES})


@pytest.mark.parametrize("group", GROUPS)
def test_renders_are_bit_identical(saved, same_kernels, group):
    keys = [k for k in CASES if _group(k) == group]
    different = [k for k in keys if not _same(_render(*CASES[k]), saved[k], same_kernels)]
    how = "bit for bit" if same_kernels else f"within {ULPS} ulp (NumPy's kernels differ from the file's)"
    assert not different, f"renders differ from the saved ones ({how}): {different}"


def test_render_classes_is_bit_identical(saved, same_kernels):
    assert _same(_render_classes(), saved["render_classes"], same_kernels)


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/test_integrator_renders.py --write  (see the docstring)")
    images = _all_renders()
    np.savez_compressed(DATA, environment=np.array(environment()), **images)
    print(f"wrote {len(images)} renders to {DATA} ({DATA.stat().st_size // 1024} KB)")
