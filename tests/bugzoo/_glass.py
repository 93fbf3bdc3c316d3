"""Helper of the glass mutants: run an integrator with the scene's dielectrics replaced."""
from pathtracer.bsdfs.dielectric import Dielectric


def with_dielectric(base, make):
    """Subclass of ``base`` whose radiance sees every Dielectric ``b`` of the scene as ``make(b)``."""

    class Mutant(base):
        def radiance(self, scene, rays, rng):
            saved = list(scene.bsdfs)
            scene.bsdfs = [make(b) if isinstance(b, Dielectric) else b for b in saved]
            try:
                return super().radiance(scene, rays, rng)
            finally:
                scene.bsdfs = saved
    return Mutant
