"""A ``null`` BSDF under ``path`` in a scene without media, as Mitsuba 3.9.1's ``path`` renders it
(rays pass through as a Dirac event of weight 1, counted as a bounce; shadow rays stop at it),
and the refusal of the integrators that render neither null boundaries nor media, located at
the element (``FILE:LINE: <element>: why``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pathtracer import SceneError, load_scene, render
from tests.budget import ALPHA

NULL_SCENE = Path(__file__).parent / "data" / "legacy" / "null-path.xml"


def null_line() -> int:
    lines = NULL_SCENE.read_text().splitlines()
    return next(i + 1 for i, line in enumerate(lines) if 'type="null"' in line)


def test_path_renders_a_null_bsdf_without_media():
    scene = load_scene(NULL_SCENE, resolution=(8, 6))
    result = render(scene, "path", spp=2, seed=1, processes=1)
    assert np.all(np.isfinite(result.mean)) and result.mean.max() > 0


@pytest.mark.parametrize("integrator", ["direct", "path_nee", "bdpt"])
def test_other_integrators_refuse_it_at_the_null_bsdf(integrator):
    scene = load_scene(NULL_SCENE, resolution=(8, 6))
    with pytest.raises(SceneError) as info:
        render(scene, integrator, spp=1, processes=1)
    assert str(info.value) == (f'null-path.xml:{null_line()}: <bsdf type="null">: integrator '
                               f"'{integrator}' does not render a null BSDF (an index-matched "
                               "boundary): use path, volpath or volpath_phase")


def test_path_refuses_media_at_the_medium():
    scene = load_scene("media-box", resolution=(8, 6))
    with pytest.raises(SceneError) as info:
        render(scene, "path", spp=1, processes=1)
    assert str(info.value).startswith('media-box.xml:58: <medium type="homogeneous">: integrator '
                                      "'path' does not render a participating medium: use "
                                      "volpath or volpath_phase")


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
def test_null_bsdf_under_path_agrees_with_mitsuba(tmp_path, monkeypatch, mi):
    from mitsuba_refs.verdicts.compare import compare
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(tmp_path))
    comparison = compare(str(NULL_SCENE), "path", spp=64, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2, resolution=(32, 24))
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()
