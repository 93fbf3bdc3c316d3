"""Shared plumbing of the lecture integrators (properties, hidden emitters).

Not an estimator: each estimator lives in its own module.
"""

import drjit as dr
import mitsuba as mi


#: True in ``scalar_*`` variants: there a null emitter/BSDF pointer is
#: ``None`` and dead lanes must not call into it, so the loop bodies return
#: early on a Python bool (always False in JIT variants, where all code is
#: masked instead).
def is_scalar():
    return not dr.is_jit_v(mi.Float)


def emitted(scene, si, active):
    """Radiance emitted by the emitter at ``si`` (the environment when ``si``
    is invalid) toward ``si.wi``; zero where there is no emitter."""
    emitter = si.emitter(scene, active)
    if is_scalar() and emitter is None:
        return mi.Spectrum(0)
    return emitter.eval(si, active)


#: ``max_depth = -1`` means unbounded; stored as the largest uint32, as
#: Mitsuba does, so ``depth + 1 < max_depth`` is always true.
_UNBOUNDED = 0xFFFFFFFF


class LectureIntegrator:
    """Mixin base: reads ``max_depth``, ``rr_depth`` and ``hide_emitters``
    exactly like Mitsuba's ``path`` plugin.

    ``mi.SamplingIntegrator`` is a different class in every Mitsuba variant,
    so the concrete classes are made per variant by :func:`make_class`.

    Parameters (scene properties)
    -----------------------------
    max_depth : int, default -1
        Longest path (in vertices); -1 = unbounded.
    rr_depth : int, default 5
        Depth from which Russian roulette is applied; must be > 0.
    hide_emitters : bool, default False
        Hide directly visible emitters.
    """

    NAME = None

    def __init__(self, props):
        mi.SamplingIntegrator.__init__(self, props)
        max_depth = int(props.get("max_depth", -1))
        if max_depth < -1:
            raise ValueError("max_depth must be -1 (unbounded) or >= 0")
        self.max_depth = _UNBOUNDED if max_depth == -1 else max_depth
        self.rr_depth = int(props.get("rr_depth", 5))
        if self.rr_depth <= 0:
            raise ValueError("rr_depth must be > 0")
        self.hide_emitters = bool(props.get("hide_emitters", False))

    def aov_names(self):
        return []

    def to_string(self):
        depth = -1 if self.max_depth == _UNBOUNDED else self.max_depth
        return (f"{type(self).__name__}[max_depth={depth}, "
                f"rr_depth={self.rr_depth}, "
                f"hide_emitters={self.hide_emitters}]")

    def first_intersection(self, scene, ray, active):
        """Intersect the camera ray; with ``hide_emitters``, continue through
        directly visible area emitters (as Mitsuba's ``path`` does)."""
        pi = scene.ray_intersect_preliminary(ray, coherent=True,
                                             active=active)
        if self.hide_emitters:
            if is_scalar():
                skip = bool(active and pi.is_valid() and
                            pi.shape.emitter() is not None)
                if not skip:
                    return pi
            else:
                skip = pi.is_valid() & (pi.shape.emitter() != None) & active  # noqa: E711  (Dr.Jit compares per lane)
            si = pi.compute_surface_interaction(ray, mi.RayFlags.Minimal,
                                                skip)
            pi_after = self.skip_area_emitters(scene, si.spawn_ray(ray.d),
                                               True, skip)
            pi[skip] = pi_after
        return pi


_classes = {}


def make_class(mixin):
    """Return a subclass of the active variant's ``mi.SamplingIntegrator``
    carrying the methods of ``mixin`` (cached per variant)."""
    key = (mixin, mi.variant())
    if key not in _classes:
        # nanobind classes take a single base: copy the mixin's methods in.
        namespace = {}
        for klass in reversed(mixin.__mro__[:-1]):
            namespace.update({k: v for k, v in vars(klass).items()
                              if k not in ("__dict__", "__weakref__")})
        _classes[key] = type(mixin.__name__, (mi.SamplingIntegrator,),
                             namespace)
    return _classes[key]
