r"""The scored render: its variance from renders the grader asks for, never from the student's word.

A submission's process answers every render request with an image *and* a per-pixel variance.
The image is what is graded; the variance scales the tests that grade it: the mean part's z
statistics and the variance part's ratio to Mitsuba's. A number the student process sends can
be anything (the runtime that computes it runs in the same process as the submission), and
either direction pays: 16 times the true variance hides a 1.7 % bias from the mean part; a
quarter of it lets a noisy estimator pass the variance part.

So the scored render of a check is :data:`REPLICAS` independent renders of ``spp / K``
samples per pixel each, with seeds the grader chooses (:func:`replica_seeds`), and

.. math::

    \bar I = \frac{1}{K}\sum_k I_k, \qquad
    s^2 = \frac{spp}{K}\,\frac{1}{K-1}\sum_k (I_k - \bar I)^2

are the image and per-sample variance every scored test uses
(:func:`mitsuba_refs.stats.replicas.replica_moments`): both come from images alone. The only
way to change the variance is to change the images, which is changing the estimator, and the
variance part grades that. The work is the same ``spp`` samples per pixel as one render.

Replicas that share their noise would make the spread too small: identical images (not constant
ones: a black image has no noise to share), or two whose
deviations correlate above :data:`MAX_SHARED_NOISE` (independent ones: near 0), fail the
check with a message (:class:`~autograder.isolation.process.StudentFailure`). A smaller shared part is
not hidden either: it is noise the spread does not see, so it inflates the mean part's
statistics and fails the mean, which the variance part needs first.

The reported variances are compared with the spread only to tell the student
(:func:`reported_variance_finding`); they are never scored.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mitsuba_refs.stats.replicas import replica_moments, shared_noise

from .isolation.process import StudentFailure

#: Independent renders of a check's scored render (``K``; ``K - 1`` = 7 degrees of freedom per
#: pixel, hundreds per 8x8 tile). Every check's ``spp`` is a multiple of it.
REPLICAS = 8
#: Seed of replica ``k`` of a render asked for with seed ``s``: ``REPLICA_SEED_BASE + REPLICA_STRIDE
#: * s + k``: apart from every other seed of a check (all < 10^6), and below the calibration's
#: 10^7 stride between repetitions, so no two repetitions share a render.
REPLICA_SEED_BASE = 5_000_000
REPLICA_STRIDE = 64
#: Replicas whose noise correlates above this share one source of it (a seed ignored).
MAX_SHARED_NOISE = 0.5
#: The reported variance differs from the spread by more than this factor (either way, summed
#: over the image): the student is told, nothing is scored on it. Two honest estimates of one
#: image variance differ by a few per cent at the checks' sizes.
REPORT_FACTOR = 2.0


@dataclass
class ScoredRender:
    """A check's scored image, from replicas.

    Attributes
    ----------
    mean, variance : arrays (H, W, 3)  image and per-sample variance from the replicas' spread
    spp : int  samples per pixel in all (``replicas * samples_per_replica``)
    replicas : int
    images, reported : arrays (K, H, W, 3)  each replica's image and the per-sample variance
        its process reported (evidence for the hints, never scored)
    """

    mean: np.ndarray
    variance: np.ndarray
    spp: int
    replicas: int
    images: np.ndarray
    reported: np.ndarray

    @property
    def reported_variance(self) -> np.ndarray:
        """The reported per-sample variance, averaged over the replicas."""
        return self.reported.mean(axis=0)

    def halves(self):
        """``(mean, reported variance), spp`` of each half of the replicas: two independent
        renders whose difference the reported variances should predict
        (:func:`autograder.hints.explain.independence`)."""
        half = self.replicas // 2
        per_replica = self.spp // self.replicas
        out = []
        for part in (slice(0, half), slice(half, None)):
            count = len(range(self.replicas)[part])
            out += [(self.images[part].mean(axis=0), self.reported[part].mean(axis=0)),
                    per_replica * count]
        return tuple(out)


def replica_seeds(seed: int, count: int = REPLICAS) -> list[int]:
    """The seeds of the ``count`` replicas of a render asked for with ``seed``."""
    return [REPLICA_SEED_BASE + REPLICA_STRIDE * int(seed) + k for k in range(count)]


def scored_render(render, scene, integrator, params, spp: int, seed: int, *,
                  replicas: int = REPLICAS, reference_noisy: bool = True) -> ScoredRender:
    """Render ``replicas`` independent images of ``spp / replicas`` samples with ``render``
    (the student's, ``render(scene, integrator, params, spp, seed) -> (mean, variance)``)
    and combine them.

    Raises
    ------
    ValueError
        ``spp`` is not a multiple of ``replicas``.
    StudentFailure
        The replicas are identical while the reference has noise, or two share their noise.
    """
    if spp % replicas or replicas < 2:
        raise ValueError(f"a scored render of {spp} spp cannot be {replicas} replicas: give the "
                         "check an spp with a divisor from 2 to 8 (a multiple of 8 keeps 7 "
                         "degrees of freedom per pixel)")
    per_replica = spp // replicas
    images, reported = [], []
    for replica_seed in replica_seeds(seed, replicas):
        mean, variance = render(scene, integrator, params, per_replica, replica_seed)
        images.append(mean)
        reported.append(variance)
    stack = np.stack(images)
    _check_independent(stack, reference_noisy)
    mean, variance = replica_moments(stack, per_replica)
    return ScoredRender(mean, variance, spp, replicas, stack, np.stack(reported))


def _check_independent(stack: np.ndarray, reference_noisy: bool) -> None:
    count = stack.shape[0]
    if np.all(stack == stack[0]):
        if not reference_noisy or np.all(stack[0] == stack[0].flat[0]):
            return      # a scene without noise, or a constant image: no noise to share
        raise StudentFailure(
            f"your integrator returned the same image for {count} different seeds: each render "
            "must draw its random numbers from the stream of its seed (the `rng` argument), "
            "so that independent renders have independent noise", "output")
    pair = shared_noise(stack)
    if pair is not None and pair[2] > MAX_SHARED_NOISE:
        raise StudentFailure(
            f"two of {count} renders with different seeds share most of their noise (their "
            f"deviations correlate at {pair[2]:.2f}; independent renders: near 0): each render "
            "must draw its random numbers "
            "from the stream of its seed (the `rng` argument)", "output")


def reported_variance_finding(render: ScoredRender) -> str | None:
    """One line for the student when the variance their renders reported is not what their
    images' spread shows (beyond :data:`REPORT_FACTOR`, summed over the image), else None."""
    spread = float(np.sum(render.variance))
    reported = float(np.sum(render.reported_variance))
    if not spread > 0 or not np.isfinite(reported):
        return None
    ratio = reported / spread
    if 1.0 / REPORT_FACTOR <= ratio <= REPORT_FACTOR:
        return None
    return (f"the variance your renders reported is {ratio:.3g}x the spread of {render.replicas} "
            f"independent renders of {render.spp // render.replicas} spp each; the grader scores "
            "with the spread, never with the reported variance")
