"""Emitters: one module per Mitsuba emitter behind one interface (:mod:`.base`), and the
scene-wide functions over all of them (:mod:`.scene_emitters`): radiance seen on hits,
next-event sampling and its pdf, light paths.

The names below are the student contract (submissions import them from ``pathtracer.emitters``).
"""
# isort: off
# Each module registers its emitter when imported; this order is the order in which the
# loader lists the supported emitters.
from . import area, point, spot, directional, constant, envmap, projector  # noqa: F401
# isort: on
from .scene_emitters import (
    EmitterPosition,
    EmitterRay,
    EmitterSample,
    check_light_paths,
    choose_emitter,
    emitted_radiance,
    emitted_towards,
    emitter_position_at,
    hit_emitter,
    pdf_emitter_direction,
    pdf_emitter_ray,
    sample_emitter,
    sample_emitter_position,
    sample_emitter_ray,
    shadowed,
)

__all__ = ["EmitterPosition", "EmitterRay", "EmitterSample", "check_light_paths", "choose_emitter",
           "emitted_radiance", "emitted_towards", "emitter_position_at", "hit_emitter",
           "pdf_emitter_direction", "pdf_emitter_ray", "sample_emitter", "sample_emitter_position",
           "sample_emitter_ray", "shadowed"]
