"""Schlick instead of exact Fresnel: the glass BSDF picks reflection with Schlick's
approximation F0 + (1 - F0)(1 - cos)^5 with the incident cosine on both sides of the
interface, so inside the glass it misses total internal reflection (rays beyond the critical
angle leave the sphere grazing instead of being reflected).

Only scenes with glass are wrong, and only visibly where total internal reflection
happens (never inside a sphere): graded on the glass cube, where the image is ~7 % too
bright.
Expected hint: the dielectric (Fresnel) code.
"""
import numpy as np
from _glass import with_dielectric
from _mutate import (
    camera_rays,  # noqa: F401  (the reference camera)
    registry,
)

from pathtracer.bsdfs.base import make_sample
from pathtracer.bsdfs.dielectric import Dielectric
from pathtracer.bsdfs.fresnel import fresnel_dielectric, reflect, refract
from pathtracer.integrators import path

BUG = "Fresnel reflectance from Schlick's approximation"
CHECK = "path-glass"
EXPECTED = ("fresnel",)


class SchlickDielectric(Dielectric):
    def __init__(self, original):
        self.__dict__.update(original.__dict__)

    def sample(self, wi, u1, u2):
        _, cos_theta_t, eta_it, eta_ti = fresnel_dielectric(wi[:, 2], self.eta)
        f0 = ((self.eta - 1) / (self.eta + 1)) ** 2
        F = f0 + (1 - f0) * (1 - np.abs(wi[:, 2])) ** 5
        selected_r = u1 <= F
        wo = np.where(selected_r[:, None], reflect(wi), refract(wi, cos_theta_t, eta_ti))
        pdf = np.where(selected_r, F, 1.0 - F)
        weight = np.where(selected_r[:, None], self.specular_reflectance,
                          self.specular_transmittance * (eta_ti * eta_ti)[:, None])
        eta = np.where(selected_r, 1.0, eta_it)
        return make_sample(wo, weight, pdf, delta=True, eta=eta, valid=np.ones(len(wi), bool))


INTEGRATORS = registry(with_dielectric(path.PathIntegrator, SchlickDielectric))
