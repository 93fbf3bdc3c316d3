"""The convergence verdict: MSE against the reference over an spp ladder, then the law.

Every level of ``CONVERGENCE_LADDER`` renders the same number of samples
(``CONVERGENCE_REPLICAS`` independent replicas at the top level, 4x as many per 4x fewer spp;
the error falls at least as N^-1/2 (one-sided: MSE slope not above -1, RMSE(N)/RMSE(4N) at
least 2, no bias floor), and the replicas double while rare
bright paths carry the error (up to ``CONVERGENCE_MAX_GROWTH``-fold).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..reference import config
from ..reference.cache import get_reference
from ..reference.rfilter import pixel_value_counts, reference_correlation
from ..settings import Settings, settings_of
from ..stats import convergence_law, image_mse_parts, rare_errors_dominate, reference_mse_floor
from .estimators import reference_integrator
from .hooks import WithOptions, mean_of
from .scenes import default_params, reference_options, render_ours

__all__ = ["CONVERGENCE_LADDER", "CONVERGENCE_REPLICAS", "CONVERGENCE_MAX_GROWTH",
           "CONVERGENCE_SEED", "INTERLEAVE", "FILTERED_MIN_SPP", "BLOCKS", "check_convergence",
           "convergence_seed", "convergence_requests", "level_replicas", "convergence_ladder",
           "ConvergenceParts", "LadderPlan", "LadderRenders", "convergence_test"]

#: spp ladder of the convergence test and its replicas at the top level (defined in config,
#: so that the command line's parser does not import the statistics).
CONVERGENCE_LADDER = config.CONVERGENCE_LADDER
CONVERGENCE_REPLICAS = config.CONVERGENCE_REPLICAS
#: The replicas double (at every level) while rare bright paths carry the mean MSE
#: (stats.rare_errors_dominate), up to this many times the first count.
CONVERGENCE_MAX_GROWTH = config.CONVERGENCE_MAX_GROWTH
#: Each replica image is split into INTERLEAVE x INTERLEAVE interleaved sub-lattices
#: (pixel (i, j) -> lattice (i mod s, j mod s)). Pixels are independent, so the
#: sub-lattices are independent pseudo-replicas that all see the whole image: the
#: mean MSE is unchanged and its uncertainty gets K * s^2 - 1 degrees of freedom
#: instead of K - 1, which is what gives the test power at a small alpha.
INTERLEAVE = 4
#: Lowest convergence level of a tent or gaussian film (ratio estimator, see convergence_test).
FILTERED_MIN_SPP = 4
#: A filtered film's renders are cut into BLOCKS x BLOCKS contiguous blocks (_spatial_blocks).
BLOCKS = 4
#: Seeds of the convergence renders: far from the comparison's others and the references'.
CONVERGENCE_SEED = 2000


def check_convergence(scene: str, integrator="path", params: dict | None = None,
                      settings: Settings | None = None, *, render=render_ours, log=None,
                      **keywords):
    """The convergence-law test alone (see :func:`mitsuba_refs.verdicts.compare.compare`).

    ``settings`` (or its fields as keywords, :func:`mitsuba_refs.settings.settings_of`) give
    ``alpha``, ``ladder``, ``replicas``, ``max_growth``, ``processes``, ``options``,
    ``resolution`` and ``reference``.

    Returns
    -------
    (ConvergenceResult, list of per-level MSE arrays)
    """
    settings = settings_of(settings, keywords, "check_convergence")
    name = integrator if isinstance(integrator, str) else integrator.name
    params = {**default_params(scene), **(params or {})}
    reference = get_reference(scene, params, settings.reference or reference_integrator(name),
                              log=log, options=reference_options(settings.options),
                              resolution=settings.resolution)
    if settings.options:
        render = WithOptions(render, settings.options)
    if settings.resolution is not None:
        render = WithOptions(render, {"resolution": tuple(settings.resolution)})
    return convergence_test(scene, integrator, params, reference, settings.alpha,
                            settings.processes, render, LadderPlan.of(settings))


def convergence_seed(level: int, replica: int) -> int:
    """Seed of replica ``replica`` at ladder level ``level`` of the convergence test."""
    return CONVERGENCE_SEED + 100_000 * level + replica


def convergence_requests(reference, ladder, replicas, top=0):
    """``(spp, seed)`` of the renders the convergence test makes when its top level grows from
    ``top`` to ``top + replicas`` replicas (``top`` = 0: its first batch)."""
    ladder = convergence_ladder(reference, ladder)
    done, wanted = level_replicas(ladder, top), level_replicas(ladder, top + replicas)
    return [(n, convergence_seed(j, k)) for j, n in enumerate(ladder)
            for k in range(done[j], wanted[j])]


def level_replicas(ladder, replicas: int) -> list[int]:
    """Independent renders per ladder level: ``replicas`` at the top, and as many below as
    give every level the same number of samples (mitsuba_refs.stats.convergence: with
    rare bright paths, fewer samples at the low levels would flatten the slope)."""
    top = ladder[-1]
    return [replicas * -(-top // n) for n in ladder]


def _spatial_blocks(height: int, width: int) -> list:
    """``BLOCKS x BLOCKS`` contiguous blocks of the image (slices).

    A tent or gaussian film correlates neighbouring pixels, so interleaved sub-lattices are
    not independent; contiguous blocks share only the samples along their borders. Blocks
    see different parts of the image, so they are paired across the ladder's levels (the
    same block at every level) rather than taken as replicas.
    """
    rows = np.array_split(np.arange(height), BLOCKS)
    cols = np.array_split(np.arange(width), BLOCKS)
    return [np.s_[r[0]:r[-1] + 1, c[0]:c[-1] + 1] for r in rows for c in cols]


def convergence_ladder(reference, ladder=CONVERGENCE_LADDER) -> tuple:
    """The spp levels used with this reference: ``ladder``, from FILTERED_MIN_SPP up for a
    tent or gaussian film. A filtered pixel is a ratio (sum w f / sum w) whose error has an
    O(1/N^2) part besides the 1/N law, which steepens the slope at 1 spp (docs/statistics.md).
    """
    if reference_correlation(reference).independent:
        return tuple(ladder)
    return tuple(n for n in ladder if n >= FILTERED_MIN_SPP) or tuple(ladder[-1:])


@dataclass
class ConvergenceParts:
    """What every convergence MSE is measured on, computed once per reference.

    Attributes
    ----------
    ladder : tuple of int
        The levels used (:func:`convergence_ladder`).
    filtered : bool
        A tent or gaussian film: contiguous blocks, paired across levels, instead of
        interleaved sub-lattices taken as replicas.
    lattices, reference_parts, floors : lists
        Per part: its slice, the reference's mean there, the reference's share of its MSE.
    whole : tuple
        The same three for the whole image (the rare-paths rule reads its MSE).
    """

    ladder: tuple
    filtered: bool
    lattices: list
    reference_parts: list
    floors: list
    whole: tuple

    @classmethod
    def of(cls, reference, ladder=CONVERGENCE_LADDER) -> ConvergenceParts:
        """The parts of ``reference`` with the spp levels ``ladder``."""
        filtered = not reference_correlation(reference).independent
        if filtered:
            lattices = _spatial_blocks(*reference.mean.shape[:2])
        else:
            lattices = [np.s_[a::INTERLEAVE, b::INTERLEAVE] for a in range(INTERLEAVE)
                        for b in range(INTERLEAVE)]
        # var / n_eff is each reference pixel's own variance (var / n with a box filter).
        ref_n = pixel_value_counts(reference)
        reference_parts = [np.asarray(reference.mean[part], dtype=np.float64) for part in lattices]
        floors = [reference_mse_floor(reference.var[part], ref_n[part]) for part in lattices]
        whole = ([np.asarray(reference.mean, dtype=np.float64)],
                 [reference_mse_floor(reference.var, ref_n)], [...])
        return cls(convergence_ladder(reference, ladder), filtered, lattices, reference_parts,
                   floors, whole)

    def mse(self, test_mean) -> list:
        """The MSE of ``test_mean`` on every part."""
        return image_mse_parts(test_mean, self.reference_parts, self.floors, self.lattices)

    def image_mse(self, test_mean) -> list:
        """The MSE of ``test_mean`` on the whole image (one value)."""
        return image_mse_parts(test_mean, *self.whole)

    def verdict(self, mse, reference, alpha, rare=False, top=0):
        """The convergence law on per-level MSE lists (one value per render and part);
        ``rare``: rare bright paths still carried the error with ``top`` replicas.

        Returns the :class:`ConvergenceResult` and the MSE arrays (for a filtered film, a
        (blocks, levels) table of each block's mean MSE).
        """
        mse = [np.array(level) for level in mse]
        if self.filtered:   # rows: blocks (each block's mean MSE over its renders), paired
            mse = np.stack([level.reshape(-1, len(self.lattices)).mean(axis=0) for level in mse],
                           axis=1)
        whole_floor = self.whole[1][0]    # the reference's share of the whole image's MSE
        law = convergence_law(np.array(self.ladder), mse, ref_mse_floor=whole_floor,
                              alpha=alpha, image_mean=float(reference.mean.mean()))
        if rare:    # the verdict says it is less reliable (report.wording)
            law = dataclasses.replace(law, rare_replicas=top)
        return law, mse


class LadderRenders:
    """The convergence renders made so far and their MSEs, grown a batch of replicas at a time.

    Attributes
    ----------
    mse : list of list
        Per ladder level, one MSE per render and part (:meth:`ConvergenceParts.mse`).
    lowest_image_mse : list
        The whole image's MSE of every render at the lowest level (the rare-paths rule).
    top : int
        Replicas rendered at the top level so far (the levels below: ``level_replicas``).
    """

    def __init__(self, parts: ConvergenceParts, render_mean, scene, integrator, params, processes):
        self.parts, self.render_mean, self.processes = parts, render_mean, processes
        self.what = (scene, integrator, params)
        self.mse = [[] for _ in parts.ladder]
        self.lowest_image_mse = []
        self.top = 0

    def grow(self, top: int) -> None:
        """Render the replicas that take the top level from ``self.top`` to ``top``."""
        ladder = self.parts.ladder
        done, wanted = level_replicas(ladder, self.top), level_replicas(ladder, top)
        for j, n in enumerate(ladder):
            for k in range(done[j], wanted[j]):
                test_mean = self.render_mean(*self.what, n, convergence_seed(j, k),
                                             processes=self.processes)
                self.mse[j] += self.parts.mse(test_mean)
                if j == 0:
                    self.lowest_image_mse += self.parts.image_mse(test_mean)
        self.top = top

    @property
    def rare(self) -> bool:
        """Whether a few renders carry the lowest level's mean MSE (rare bright paths)."""
        return rare_errors_dominate(self.lowest_image_mse)


@dataclass(frozen=True)
class LadderPlan:
    """What the convergence test renders and how often it looks.

    Attributes
    ----------
    ladder : tuple of int
        The spp levels (:func:`convergence_ladder` may drop the lowest for a filtered film).
    replicas : int
        Independent renders at the top level (as many samples at every level).
    max_growth : int
        The replicas double while rare bright paths carry the error, up to this many times.
    early_stop : bool
        Two looks (compare with a tolerance), the first after half the replicas.
    """

    ladder: tuple = CONVERGENCE_LADDER
    replicas: int = CONVERGENCE_REPLICAS
    max_growth: int = CONVERGENCE_MAX_GROWTH
    early_stop: bool = False

    @classmethod
    def of(cls, settings: Settings) -> LadderPlan:
        """The plan of ``settings``: its ladder, replicas and growth; two looks with a tolerance."""
        return cls(tuple(settings.ladder), settings.replicas, settings.max_growth,
                   settings.tolerance is not None)

    @property
    def first_look(self) -> int:
        """Top-level replicas before the first look: half of ``replicas`` (at least one) with
        ``early_stop``, else all of them."""
        return max(1, self.replicas // 2) if self.early_stop else self.replicas

    @property
    def looks(self) -> int:
        """How many times the law is judged, each at ``alpha / looks``: 2 when the first look
        comes before all the replicas, else 1."""
        return 2 if self.first_look < self.replicas else 1


def convergence_test(scene, integrator, params, reference, alpha, processes, render,
                     plan: LadderPlan = LadderPlan()):
    """MSE(N) over the ladder with equal work per level, then the convergence law.

    Starts with ``plan.replicas`` renders at the top level and doubles the renders of every
    level while a few renders carry the lowest level's mean MSE, at most
    ``plan.max_growth``-fold. With ``plan.early_stop`` (compare with a tolerance:
    docs/statistics.md, section 9) the test looks twice, each look at ``alpha / 2``
    (Bonferroni): first after half the top-level replicas, where a law already rejected (a
    clear bias floor, an error that does not fall) ends the test unless rare bright paths
    carry the error, then as without it.

    Returns the :class:`ConvergenceResult` and the MSEs:
    one array per level, with one value per render and sub-lattice; for a tent or gaussian
    film a (blocks, levels) table of each block's mean MSE.
    """
    parts = ConvergenceParts.of(reference, plan.ladder)
    replicas = plan.replicas
    renders = LadderRenders(parts, getattr(render, "render_mean", None) or mean_of(render),
                            scene, integrator, params, processes)
    alpha_look = alpha / plan.looks
    renders.grow(plan.first_look)
    if plan.looks == 2:
        law, table = parts.verdict(renders.mse, reference, alpha_look)
        if not law.passed and not renders.rare:
            return dataclasses.replace(law, looks=2, stopped_early=True), table
        renders.grow(replicas)
    while renders.rare and renders.top < replicas * plan.max_growth:
        renders.grow(2 * renders.top)
    law, table = parts.verdict(renders.mse, reference, alpha_look, renders.rare, renders.top)
    return dataclasses.replace(law, looks=plan.looks), table
