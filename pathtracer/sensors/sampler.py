"""Mitsuba's samplers: the sample count and seed of a ``<sampler>``.

Every Mitsuba sampler draws uniform samples whose expectation is the same image; this tracer
draws independent ones whatever the type, and says so once per type
(:func:`_warn_sampler`).
"""
from __future__ import annotations

import warnings

from ..core.rng import SEED_MAX
from ..scene.properties import Props, children, registered
from ..scene.registry import register
from ..scene.xml import Plugin

#: Mitsuba's samplers and their parameters besides sample_count and seed.
SAMPLER_PARAMS = {"independent": (), "stratified": ("jitter",), "multijitter": ("jitter",),
                  "orthogonal": ("jitter", "strength"), "ldsampler": ()}
_warned_samplers: set = set()


def build_sampler(plugin: Plugin) -> tuple[int, int]:
    """``(sample_count, seed)`` of a ``<sampler>`` (a sensor's or a top-level one)."""
    create = registered(plugin, "sampler")
    return create(Props(plugin))


@register("sampler", *SAMPLER_PARAMS)
def create(props: Props) -> tuple[int, int]:
    """``sample_count`` (4) and ``seed`` (0); the type's own parameters are accepted and unused."""
    plugin = props.plugin
    children(plugin, {})
    props.ignore(*SAMPLER_PARAMS[plugin.type])
    _warn_sampler(plugin)
    spp, seed = props.int("sample_count", 4), props.int("seed", 0)
    if spp <= 0:
        raise plugin.error("sample_count must be positive", props.line("sample_count"))
    if not 0 <= seed <= SEED_MAX:
        raise plugin.error(f"seed must lie in [0, {SEED_MAX}] (an unsigned 32-bit integer, as "
                           f"in Mitsuba), got {seed}", props.line("seed"))
    props.finish()
    return spp, seed


def _warn_sampler(plugin: Plugin) -> None:
    """Say once per sampler type that the tracer samples independently (and so does the
    reference): stratified patterns would lower Mitsuba's per-pixel variance."""
    if plugin.type == "independent" or plugin.type in _warned_samplers:
        return
    _warned_samplers.add(plugin.type)
    warnings.warn(f"{plugin.file}:{plugin.line}: <sampler type=\"{plugin.type}\">: rendered with "
                  "independent samples (same expected image); mitsuba-refs renders its reference "
                  f"with an independent sampler too, because {plugin.type} sampling has a lower "
                  "per-pixel variance than the comparison's independent-sample statistics assume",
                  stacklevel=5)
