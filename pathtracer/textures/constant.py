"""Mitsuba's ``rawconstant`` texture: one value everywhere, used as given."""
from __future__ import annotations

import numpy as np

from ..scene.properties import Props, children
from ..scene.registry import register
from .base import ConstantTexture


@register("texture", "rawconstant")
def create(props: Props) -> ConstantTexture:
    """``value``: used as given (no colour conversion, no range check), a float or a vector."""
    plugin = props.plugin
    children(plugin, {"texture": 2})
    props.transform("to_uv")   # accepted: a constant is the same under any transform
    value = props._get("value", ("float", "integer", "vector", "point", "rgb"),
                       "a <float> or a <vector>")
    if value is None:
        raise plugin.error("missing \"value\" (a <float> or a <vector>)")
    props.finish()
    return ConstantTexture(np.asarray(value, dtype=float))
