"""The convergence verdict with two looks (``compare --tolerance``): a law already rejected after
half the ladder's renders ends the test there (mitsuba_refs.verdicts.convergence.convergence_test,
``early_stop``); otherwise it looks again with every render, each look at alpha / 2."""
from types import SimpleNamespace

import numpy as np
import pytest

from mitsuba_refs.external.check import _GrowingLadder
from mitsuba_refs.report.verdicts import convergence_entry
from mitsuba_refs.report.wording import convergence_verdict
from mitsuba_refs.stats.simulate import make_scene, render_means, render_stats
from mitsuba_refs.verdicts.compare import compare
from mitsuba_refs.verdicts.convergence import (
    CONVERGENCE_SEED,
    LadderPlan,
    convergence_seed,
    convergence_test,
    level_replicas,
)
from mitsuba_refs.verdicts.scenes import render_ours
from tests.budget import ALPHA

LADDER = (1, 4, 16, 64)
#: Renders of the whole test (2 replicas at the top) and of its first look (1).
ALL_RENDERS, HALF_RENDERS = sum(level_replicas(LADDER, 2)), sum(level_replicas(LADDER, 1))
SCENE = make_scene(32, 32, seed=3, p_range=(0.1, 0.6))


def _reference():
    mean, var = (a[0] for a in render_stats(SCENE, 16384, 1, np.random.default_rng(99)))
    return SimpleNamespace(mean=mean, var=var, n=16384, metadata={})


class Simulated:
    """The simulated scene's mean images, every sample ``scale`` times too bright; ``spikes``:
    the first render at 1 spp gets one enormous pixel (a rare bright path)."""

    def __init__(self, scale=1.0, spikes=False, seed=7):
        self.scale, self.spikes, self.seed, self.calls = scale, spikes, seed, 0

    def __call__(self, _scene, _integrator, _params, spp, seed, processes=None):
        self.calls += 1
        mean = render_means(SCENE, spp, 1, np.random.default_rng([self.seed, seed]),
                            scale=self.scale)[0]
        if self.spikes and spp == 1 and self.calls == 1:
            mean[5, 5] += 1e5
        return mean, None


def _law(render, early_stop):
    return convergence_test("sim", "path", {}, _reference(), ALPHA, None, render,
                            LadderPlan(LADDER, 2, early_stop=early_stop))[0]


def test_the_first_look_takes_half_the_replicas():
    assert LadderPlan(replicas=2, early_stop=True).first_look == 1
    assert LadderPlan(replicas=8, early_stop=True).first_look == 4
    assert LadderPlan(replicas=2, early_stop=True).looks == 2
    one = LadderPlan(replicas=1, early_stop=True)     # one replica: one look
    assert one.first_look == 1 and one.looks == 1
    assert LadderPlan(replicas=2).first_look == 2 and LadderPlan(replicas=2).looks == 1
    assert (ALL_RENDERS, HALF_RENDERS) == (170, 85)


@pytest.mark.statistical(assertions=1)
def test_a_correct_renderer_is_looked_at_twice_and_passes():
    render = Simulated()
    law = _law(render, early_stop=True)
    assert law.passed and law.looks == 2 and not law.stopped_early
    assert render.calls == ALL_RENDERS
    assert "2 looks, each at alpha/2" in convergence_verdict(law)


@pytest.mark.statistical(assertions=1)
def test_a_renderer_twenty_percent_too_bright_stops_at_the_first_look_with_half_the_renders():
    render = Simulated(scale=1.2)
    law = _law(render, early_stop=True)
    assert not law.passed and law.stopped_early
    assert render.calls == HALF_RENDERS
    assert "decided at the first of 2 looks" in convergence_verdict(law)
    once = Simulated(scale=1.2)
    assert _law(once, early_stop=False).looks == 1 and once.calls == ALL_RENDERS


def test_rare_bright_paths_at_the_first_look_do_not_end_the_test():
    # Rare paths make the first look's error unreliable: the test goes on (and grows).
    render = Simulated(scale=1.2, spikes=True)
    law = _law(render, early_stop=True)
    assert not law.stopped_early and render.calls >= ALL_RENDERS


class Scaled:
    """Our ``path`` with its image ``factor`` times too bright."""

    def __init__(self, factor):
        self.factor = factor

    def __call__(self, scene, integrator, params, spp, seed, **keywords):
        mean, variance = render_ours(scene, integrator, params, spp, seed, **keywords)
        return mean * self.factor, variance * self.factor ** 2


@pytest.mark.statistical(assertions=1)
def test_compare_with_a_tolerance_stops_the_ladder_of_a_renderer_twenty_percent_too_bright():
    result = compare("cornell-box", "path", tolerance=2, spp=64, render=Scaled(1.2),
                     bounces=False, alpha=ALPHA, ladder=(4, 16, 64))
    law = result.convergence
    assert result.outcome == "DISAGREES" and not law.passed and law.stopped_early
    ladder_runs = [run for run in result.runs if run["purpose"] == "convergence"]
    assert len(ladder_runs) == sum(level_replicas((4, 16, 64), 1))
    entry = convergence_entry(result)
    assert entry["looks"] == 2 and entry["stopped_early"] is True


def test_check_plans_the_rest_of_the_first_look_then_doubles():
    class Renders:
        def request(self, n, seed, max_depth, variance):
            return n, seed

    reference = _reference()
    asked = SimpleNamespace(variance=False, seed=CONVERGENCE_SEED, max_depth=None)
    grow = _GrowingLadder(Renders(), reference, LADDER, 1, 3)      # odd replicas: 1, then 3
    top = len(LADDER) - 1
    rest = grow(asked)
    assert [seed for n, seed in rest if n == 64] == [convergence_seed(top, k) for k in (1, 2)]
    doubled = grow(asked)
    assert [seed for n, seed in doubled if n == 64] == [convergence_seed(top, k) for k in (3, 4, 5)]
    assert grow(SimpleNamespace(variance=True, seed=CONVERGENCE_SEED, max_depth=None)) is None
