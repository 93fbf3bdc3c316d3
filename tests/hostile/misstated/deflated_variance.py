"""Misstated variance, deflated: a correct but noisy estimator that reports a tenth of its
variance.

One shadow ray and no MIS, and each sample kept with probability 1/2 and doubled (a coin flip
at the first hit): the mean is right, the per-sample variance about 11x Mitsuba's here, so the
variance part (at most 1.5x) must fail; a tenth of it (1.1x) would pass.

EXPECT: the variance part scores zero (the grader measures the variance from the spread of 8
renders it asks for); the mean and convergence parts, which it does not attack, keep their
points; a finding says the reported variance is about 0.1x the spread.
"""
from _own_direct import own_direct, registry, report_variance_times

EXPECT = dict(check="direct-cornell-box", zero=("variance",), misstated=0.1)


def radiance(self, scene, rays, rng):
    coin = rng.next_1d() < 0.5
    return own_direct(self, scene, rays, rng) * (2.0 * coin)[:, None]


report_variance_times(0.1)
INTEGRATORS = registry(radiance)
