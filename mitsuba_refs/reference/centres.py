"""Mitsuba's image of the pixel centres: every sample of a pixel through its centre.

A renderer that puts some of its pixel samples at the pixel centre (Cycles' first sample,
or a tracer without antialiasing) estimates a mix of the pixel's integral, Mitsuba's
box-filtered reference, and this image (:mod:`mitsuba_refs.verdicts.conventions`). No film
of Mitsuba draws it: here each sample is Mitsuba's own camera ray of the pixel centre
(``sensor.sample_ray``) traced by Mitsuba's own estimator (``integrator.sample``), one
Python call per sample in ``scalar_rgb`` (about 7 microseconds each for the Cornell box at
max_depth 3 on an AMD EPYC), so the sample count is kept to :data:`MAX_CALLS` per image.
It is rendered only to explain a disagreement, and kept in memory (the last
:data:`KEPT` images) for the next one in the same process; not on disk.
"""
from __future__ import annotations

import hashlib
from types import SimpleNamespace

import numpy as np

from .render import integrator_dict, load_mitsuba_scene, reference_settings, resolve_scene
from .variant import set_variant

__all__ = ["MAX_CALLS", "MIN_SPP", "centre_spp", "render_centres"]

#: Samples (Python calls) one image of the centres may take: 128 spp at 64 x 64 (10.6 s on an
#: AMD EPYC's 2 vCPUs under a load average of 8; docs/external.md).
MAX_CALLS = 1 << 19
#: Fewest samples per pixel (a per-sample variance needs two; 16 keeps it steady).
MIN_SPP = 16
#: Images of the centres kept in memory, by what they are.
KEPT = 4
_kept: dict = {}
#: The estimators whose ``sample`` traces a camera ray (Mitsuba's particle tracer does not).
CAMERA_ESTIMATORS = ("path", "direct")


def centre_spp(width: int, height: int) -> int:
    """Samples per pixel of a ``width`` x ``height`` image of the centres: a power of two
    within :data:`MAX_CALLS`, at least :data:`MIN_SPP`."""
    budget = max(MAX_CALLS // (width * height), MIN_SPP)
    return 1 << (budget.bit_length() - 1)


def _pixel_seeds(key: str, count: int) -> np.ndarray:
    """One 32-bit seed per pixel, hashed from ``key``: unrelated to any seed a renderer
    under test derives from its own (seed + pixel, seed x pixels + block)."""
    digest = hashlib.sha256(key.encode()).digest()
    rng = np.random.default_rng(int.from_bytes(digest[:8], "little"))
    return rng.integers(0, 1 << 32, count, dtype=np.uint64)


def render_centres(scene, params, integrator: str, *, options=None, resolution=None,
                   spp: int | None = None):
    """The image of the pixel centres of ``scene`` as Mitsuba renders its reference.

    Parameters
    ----------
    scene : str or Path
        Scene file or built-in name.
    params, integrator, options, resolution
        As :func:`mitsuba_refs.reference.render.render_reference` takes them.
    spp : int, optional
        Samples per pixel (default :func:`centre_spp`).

    Returns
    -------
    SimpleNamespace
        ``mean`` and per-sample ``var`` (H, W, 3) float64, ``n`` samples per pixel and
        ``metadata`` (a box film: each sample counts in its pixel only).

    Raises
    ------
    ValueError
        For an estimator that does not trace camera rays (the particle tracer).
    """
    path = resolve_scene(scene)
    scene_kw, transport, settings = reference_settings(path, params, options, resolution)
    nested = integrator_dict(integrator, transport, settings.integrator)
    if nested["type"] not in CAMERA_ESTIMATORS:
        raise ValueError(f"{path}: no image of the pixel centres for Mitsuba's {nested['type']}")
    width, height = settings.resolution
    spp = spp or centre_spp(width, height)
    key = f"{path.read_text()}|{sorted(scene_kw.items())}|{nested}|{resolution}|{spp}"
    if key not in _kept:
        set_variant("scalar_rgb")
        import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
        loaded = load_mitsuba_scene(path, scene_kw, resolution)
        _kept[key] = _render(loaded, mi.load_dict(nested), (width, height), spp,
                             _pixel_seeds(key, width * height))
        while len(_kept) > KEPT:
            _kept.pop(next(iter(_kept)))
    mean, var = _kept[key]
    return SimpleNamespace(mean=mean, var=var, n=spp,
                           metadata={"rfilter": {"type": "box", "radius": 0.5},
                                     "mitsuba_integrator": nested, "centres": True,
                                     "integrator": integrator})


def _render(loaded, estimator, size, spp: int, seeds):
    """``(mean, per-sample variance)`` of ``spp`` samples through every pixel centre of the
    loaded scene's first sensor, one seed per pixel."""
    import mitsuba as mi  # Mitsuba: optional and heavy, imported where it renders
    width, height = size
    sensor = loaded.sensors()[0]
    sampler = mi.load_dict({"type": "independent"})
    samples = np.empty((height, width, spp, 3))
    for y in range(height):
        for x in range(width):
            sampler.seed(int(seeds[y * width + x]))
            centre = mi.Point2f((x + 0.5) / width, (y + 0.5) / height)
            for k in range(spp):
                ray, weight = sensor.sample_ray(0.0, sampler.next_1d(), centre, sampler.next_2d())
                radiance = estimator.sample(loaded, sampler, ray)[0]
                samples[y, x, k] = np.array(radiance) * np.array(weight)
    return samples.mean(axis=2), samples.var(axis=2, ddof=1)


