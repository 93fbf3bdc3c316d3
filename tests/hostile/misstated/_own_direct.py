"""Shared by the misstated-variance submissions: the way a submission changes the variance its
process reports, and a student's own direct-lighting estimator.

The estimator is written from the slide, as a student would (one shadow ray, no MIS)::

    L = Le(x1) + f(x1) cos Le V / p_light

On scenes whose BSDFs are all smooth (the Cornell box) its mean is that of Mitsuba's
``direct``; without MIS its variance is higher.

The reported variance comes from the render driver, which runs in the student's own process:
replacing ``pathtracer.render`` there changes every number the grader is sent.
"""
import pathtracer
from pathtracer.integrators.base import Integrator

NAMES = ("direct",)


def own_direct(integrator, scene, rays, rng):
    """One sample of direct lighting along each camera ray."""
    paths = integrator.camera_paths(scene, rays, rng)
    if not paths:
        return paths.L
    paths.add_radiance(integrator.emission(scene, paths.hit, paths.wi, paths.depth))
    paths.keep(paths.hit.valid & (paths.depth + 1 < integrator.depth_limit))
    if paths:
        paths.add_radiance(integrator.sample_direct(scene, paths))
    return paths.L


def registry(radiance) -> dict:
    """The integrators a check may ask for, each with ``radiance``."""
    return {name: type(f"Own_{name}", (Integrator,), {"name": name, "radiance": radiance})
            for name in NAMES}


def report_variance_times(factor: float) -> None:
    """From now on this process reports ``factor`` times every render's variance."""
    honest = pathtracer.render

    def render(*args, **kwargs):
        result = honest(*args, **kwargs)
        result.variance = result.variance * factor
        return result

    pathtracer.render = render
