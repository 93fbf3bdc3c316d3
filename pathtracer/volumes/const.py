"""Mitsuba's ``constvolume``: one value everywhere in its box."""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props, children
from ..scene.registry import register
from .base import Volume, invert


class ConstVolume(Volume):
    """The value ``value`` (3,) everywhere; its box is ``to_world`` of the unit cube."""

    def __init__(self, value, to_local=np.eye(4)):
        super().__init__(to_local)
        self.value = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,)).copy()

    def eval(self, p: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self.value, (len(p), 3)).copy()

    def max(self) -> float:
        return float(self.value.max())

    def is_grey(self) -> bool:
        return bool(np.ptp(self.value) == 0)


@register("volume", "constvolume")
def create(props: Props) -> ConstVolume:
    """``value`` (1): a ``<float>``, ``<rgb>`` or ``<spectrum>``, any magnitude (Mitsuba reads
    it as an unbounded texture); ``to_world`` (identity) places its unit cube."""
    plugin = props.plugin
    children(plugin, {})
    value = props.color("value", 1.0, "unbounded")
    to_world = props.transform("to_world")
    props.finish()
    if not np.all(np.isfinite(value)):
        raise plugin.error("value must be finite", props.line("value"))
    return ConstVolume(value, invert(plugin, props, to_world))
