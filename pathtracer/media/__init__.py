"""Participating media: homogeneous and heterogeneous media, phase functions, free-flight
sampling and transmittance with medium tracking.

The names below are the student contract (submissions import them from ``pathtracer.media``).
"""
from .heterogeneous import HeterogeneousMedium
from .homogeneous import (
                          MIXTURE,
                          FreeFlight,
                          HomogeneousMedium,
                          camera_medium,
                          choose_channel,
                          has_media,
                          next_medium,
                          null_event,
                          null_transmission,
                          phase_eval,
                          phase_sample,
                          sample_free_flight,
                          samples_emitters,
                          shadow_transmittance,
)
from .phase import HenyeyGreensteinPhase, IsotropicPhase

__all__ = ["MIXTURE", "FreeFlight", "HenyeyGreensteinPhase", "HeterogeneousMedium", "HomogeneousMedium",
           "IsotropicPhase",
           "camera_medium", "choose_channel", "has_media", "next_medium", "null_event",
           "null_transmission", "phase_eval", "phase_sample", "sample_free_flight",
           "samples_emitters", "shadow_transmittance"]
