"""Misstated variance, inflated: Mitsuba's own direct estimator, 1.5 % too bright (the bias every
mean part must detect, docs/autograder.md "Power"), reporting 100 times its variance.

With its variance believed, the mean part's own-variance statistics shrink by 10 and the bias
hides: on the Cornell box the bounded-variance component alone rejects only above 2 %. (A
hand-written ``direct`` reporting 16x did this on Gradescope: 4 of 4 points, p = 1.9e-3; with
this estimator the quietest tiles need more.) The estimator is the reference
solution's, so this submission is graded in the solution runtime as the bug zoo is; the lie is
in what the process reports, which is the same code in the student runtime.

EXPECT: the mean part scores zero (the variance comes from the spread of 8 renders the grader
asks for), so does every part that needs a right mean; a finding says the reported variance
is about 100x the spread.
"""
from _own_direct import report_variance_times

from pathtracer.camera import camera_rays  # noqa: F401  (the reference camera)
from pathtracer.integrators import INTEGRATORS as REFERENCE
from pathtracer.integrators.direct import DirectIntegrator

EXPECT = dict(check="direct-cornell-box", trusted=True, zero=("mean", "variance", "convergence"),
              misstated=100.0)
BIAS = 1.015


class Brighter(DirectIntegrator):
    def radiance(self, scene, rays, rng):
        return BIAS * super().radiance(scene, rays, rng)


report_variance_times(100.0)
INTEGRATORS = {**REFERENCE, "direct": Brighter}
