"""Every integrator on every built-in scene against the committed Mitsuba 3 references
(and the feature scenes, e.g. ``materials``, with the estimators they have references for).

Mean: tile-aggregated z test against Mitsuba's ``path`` (or the same estimator).
Variance: where Mitsuba runs the same estimator (path, path_bsdf, path_nee,
direct), the per-sample variance ratio must be 1. Each assertion uses the
suite's per-test alpha (tests/budget.py). References are committed, so these
run without Mitsuba.
"""
import pytest

from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.estimators import SAME_ESTIMATOR
from pathtracer import INTEGRATORS
from tests.budget import ALPHA
from tests.scenes import AGREEMENT_CASES, FEATURE_CASES, NOISELESS, SURFACE_INTEGRATORS, integrator_options, spp_for
from tests.test_media import VOLUMETRIC

pytestmark = pytest.mark.statistical(assertions=2)


@pytest.mark.parametrize("scene,integrator", AGREEMENT_CASES + FEATURE_CASES)
def test_mean_and_variance_agree_with_mitsuba(scene, integrator):
    comparison = compare(scene, integrator, spp=spp_for(integrator), alpha=ALPHA,
                         convergence=False, bounces=False, processes=2,
                         options=integrator_options(integrator))
    assert comparison.mean.agree, comparison.report()
    if (scene, integrator) in NOISELESS:
        assert comparison.variance is None, comparison.report()
    elif integrator in SAME_ESTIMATOR:
        assert comparison.variance is not None and comparison.variance.agree, comparison.report()


def test_every_integrator_is_covered():
    assert {i for _, i in AGREEMENT_CASES} == set(SURFACE_INTEGRATORS)
    assert set(INTEGRATORS) - set(SURFACE_INTEGRATORS) == set(VOLUMETRIC)   # test_media.py


#: The textured scene's committed reference: ``path`` at 32 x 32 (mitsuba-refs build
#: textured --integrators path -D width=32 -D height=32 --no-per-bounce).
TEXTURED_PARAMS = {"width": 32, "height": 32}


def test_textured_scene_agrees_with_mitsuba():
    """Bitmap (PNG, sRGB and raw; nearest, bilinear; repeat, mirror, clamp; to_uv) and
    checkerboard textures on a rectangle, sphere, cube and disk, as reflectance and as
    a mirror's specular_reflectance."""
    comparison = compare("textured", "path", TEXTURED_PARAMS, spp=64, alpha=ALPHA,
                         convergence=False, bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()


@pytest.mark.parametrize("rfilter", ["tent", "gaussian"])
def test_filtered_film_agrees_with_mitsuba(rfilter):
    """The quad-light scene on a tent / gaussian film against Mitsuba's film with the same
    filter (committed references): mean and variance, with the statistics for correlated
    pixels (docs/statistics.md, "Reconstruction filters")."""
    params = {"rfilter": rfilter, "width": 64, "height": 48}
    comparison = compare("quad-light-filtered", "path", params, spp=32, alpha=ALPHA,
                         convergence=False, bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()


def test_lights_and_cameras_scene_agrees_with_mitsuba():
    """A thin-lens camera (depth of field), mesh attributes (vertex colours as a reflectance,
    a face attribute as a roughness), area lights with a bitmap and a checkerboard radiance
    (sampled by the texture) and two projectors: the committed ``path`` reference at 32 x 24
    (mitsuba-refs build lights-cameras --integrators path --no-per-bounce)."""
    comparison = compare("lights-cameras", "path", spp=64, alpha=ALPHA,
                         convergence=False, bounces=False, processes=2)
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()
