"""``<medium>`` and ``<phase>`` elements, and which media shapes and the sensor carry.

Mitsuba 3's ``homogeneous`` medium takes ``sigma_t`` (extinction) and
``albedo`` (single-scattering albedo), each a ``<float>``, an ``<rgb>`` or a
``<spectrum>``, and ``scale`` multiplying ``sigma_t``. An ``<rgb>`` sigma_t must
lie in [0, 1] (Mitsuba reads it as a reflectance); larger extinctions are
written with ``scale``. ``sigma_a`` / ``sigma_s`` are Mitsuba 0.6's parameters,
which Mitsuba 3 refuses; the error says the equivalent ``sigma_t`` and ``albedo``.
A shape takes the media on its two sides as ``<medium name="interior">`` /
``name="exterior"`` (nested or ``<ref id=".." name=".."/>``); the sensor takes one
medium, the one the camera sits in.
"""
from __future__ import annotations

import numpy as np

from ..media.homogeneous import HomogeneousMedium
from ..media.phase import HenyeyGreensteinPhase, IsotropicPhase
from .properties import Props, children, unsupported
from .xml import Plugin

SHAPE_MEDIUM_NAMES = ("interior", "exterior")


class MediaTable:
    """The scene's media, each built once per ``<medium>`` element (shared by ``<ref>``)."""

    def __init__(self):
        self.media: list[HomogeneousMedium] = []
        self._index: dict[int, int] = {}

    def index(self, plugin: Plugin) -> int:
        """Index of the medium of ``plugin`` in :attr:`media` (building it the first time)."""
        key = id(plugin)
        if key not in self._index:
            self.media.append(build_medium(plugin))
            self._index[key] = len(self.media) - 1
        return self._index[key]

    def shape_media(self, shape: Plugin) -> tuple[int, int]:
        """(interior, exterior) medium indices of a shape, -1 where none is given."""
        sides = {}
        for name, child in shape.named_children():
            if child.kind != "medium":
                continue
            if name not in SHAPE_MEDIUM_NAMES:
                raise child.error(f"a <medium> inside {shape.label} needs name=\"interior\" or "
                                  f"name=\"exterior\" (got {name!r})")
            if name in sides:
                raise child.error(f"{shape.label} has two {name} media")
            sides[name] = self.index(child)
        return sides.get("interior", -1), sides.get("exterior", -1)

    def sensor_medium(self, sensor: Plugin) -> int:
        """The medium the camera is in, -1 for vacuum."""
        media = [c for c in sensor.children if c.kind == "medium"]
        return self.index(media[0]) if media else -1


def build_medium(plugin: Plugin) -> HomogeneousMedium:
    """The :class:`~pathtracer.media.HomogeneousMedium` of a ``<medium>`` element."""
    if plugin.type not in ("homogeneous",):
        raise unsupported(plugin, "medium")
    props = Props(plugin)
    kids = children(plugin, {"phase": 1})
    if props.has("sigma_a") or props.has("sigma_s"):
        raise _mitsuba06_coefficients(plugin, props)
    sigma_t = props.color("sigma_t", 1.0)
    if props.has("sigma_t") and plugin.props["sigma_t"].tag == "rgb" and not np.all(
            (sigma_t >= 0) & (sigma_t <= 1)):
        raise plugin.error("an <rgb> sigma_t must lie in [0, 1] (Mitsuba reads it as a "
                           "reflectance); give the extinction's colour there and its "
                           "magnitude in <float name=\"scale\">", props.line("sigma_t"))
    if not np.all(sigma_t >= 0):
        raise plugin.error("sigma_t must be >= 0", props.line("sigma_t"))
    albedo = props.reflectance("albedo", 0.75)
    scale = props.float("scale", 1.0)
    if not (np.isfinite(scale) and scale >= 0):
        raise plugin.error(f"scale must be a finite number >= 0, got {scale}", props.line("scale"))
    sample_emitters = props.bool("sample_emitters", True)
    if not props.bool("has_spectral_extinction", True) and np.ptp(sigma_t) > 0:
        raise plugin.error("has_spectral_extinction=false with a coloured sigma_t is not "
                           "supported (Mitsuba then samples distances with the wrong "
                           "weights); leave it true", props.line("has_spectral_extinction"))
    props.finish()
    phase = build_phase(kids["phase"][0]) if kids["phase"] else IsotropicPhase()
    return HomogeneousMedium(sigma_t * scale, albedo, phase, sample_emitters,
                             name=f"homogeneous ({plugin.file}:{plugin.line})")


def _mitsuba06_coefficients(plugin: Plugin, props: Props):
    """The error for Mitsuba 0.6's sigma_a / sigma_s, with the Mitsuba 3 equivalent."""
    name = "sigma_a" if props.has("sigma_a") else "sigma_s"
    text = ""
    if props.has("sigma_a") and props.has("sigma_s"):
        sigma_a, sigma_s = props.color("sigma_a", 0.0, "unbounded"), props.color("sigma_s", 0.0, "unbounded")
        total = sigma_a + sigma_s
        albedo = np.where(total > 0, sigma_s / np.where(total > 0, total, 1), 0)
        text = (f": sigma_t = sigma_a + sigma_s = {', '.join(f'{v:g}' for v in total)}, "
                f"albedo = sigma_s / sigma_t = {', '.join(f'{v:.6g}' for v in albedo)}")
    return plugin.error(f"\"{name}\" is Mitsuba 0.6's; Mitsuba 3's homogeneous medium takes "
                        f"sigma_t and albedo{text}", props.line(name))


def build_phase(plugin: Plugin):
    """The :mod:`pathtracer.phase` object of a ``<phase>`` element."""
    if plugin.type not in ("isotropic", "hg"):
        raise unsupported(plugin, "phase function")
    props = Props(plugin)
    children(plugin, {})
    if plugin.type == "isotropic":
        props.finish()
        return IsotropicPhase()
    g = props.float("g", 0.8)
    if not -1.0 < g < 1.0:
        raise plugin.error(f"g must lie in (-1, 1), got {g}", props.line("g"))
    props.finish()
    return HenyeyGreensteinPhase(g)
