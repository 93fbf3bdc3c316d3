"""Light choice without its probability: path_nee picks one of the scene's N lights uniformly
but divides the shadow ray's contribution only by the pdf of the point on that light, not by
the 1/N of having chosen it (``emitter = int(u * N)``, then ``Le f cos / p_point``).

With one light nothing changes; with the two lights of cornell-lights every shadow ray
counts half of what it should: direct light (bounce 2) is x0.5, the image darker.
Expected hint: the 1/N of choosing one of the N lights.
"""
from _lightpdf import scale_sample
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    mutate,
    registry,
)

from pathtracer.integrators import base, path_nee

BUG = "one of N lights chosen uniformly, its 1/N choice probability left out of the pdf"
CHECK = "path_nee-lights"
EXPECTED = ("1/n",)


def _without_choice(sample_emitter):
    def buggy(scene, hit, u_choice, u, test_visibility=True, emitter=None):
        sample = sample_emitter(scene, hit, u_choice, u, test_visibility, emitter)
        # The reference's pdf includes 1/N; the student's is N times larger.
        return scale_sample(sample, float(scene.num_emitters))
    return buggy


# Shadow rays are sampled in base.Integrator.sample_direct.
INTEGRATORS = registry(mutate(path_nee.PathNEEIntegrator, base, sample_emitter=_without_choice))
