"""The detectable-bias closed forms under their former name: they live in
:mod:`mitsuba_refs.stats.detectable`, the one home of the detectable-bias math.

Kept only for :mod:`autograder.power`, which imports ``gross_error_bound`` and
``tile_gross_error_bound`` from here; import them from :mod:`mitsuba_refs.stats.detectable`.
"""
from __future__ import annotations

from .detectable import (
    bias_power,
    detectable_bias,
    gross_error_bound,
    image_critical_z,
    image_mean_se,
    spp_for_bias,
    tile_gross_error_bound,
)

__all__ = ["image_mean_se", "image_critical_z", "bias_power", "detectable_bias", "spp_for_bias",
           "gross_error_bound", "tile_gross_error_bound"]
