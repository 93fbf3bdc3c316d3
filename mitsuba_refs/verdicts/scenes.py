"""The scene both sides render: our renders of it, its defaults, and a cache of loaded scenes.

The convergence test renders a scene up to hundreds of times; :func:`loaded_scene` loads it
(and builds a mesh's BVH) once while its files are unchanged.
"""
from __future__ import annotations

import functools

from pathtracer import load_scene, render
from pathtracer.render.driver import SCENE_OPTIONS

from ..reference import config
from ..reference.cache import scene_hash
from ..reference.render import resolve_scene, xml_defaults

__all__ = ["default_params", "render_ours", "reference_options", "scene_defaults", "loaded_scene"]


def default_params(scene: str) -> dict:
    """The test film size of a built-in scene (the committed references' resolution)."""
    if scene in config.BUILTIN_SCENES or scene in config.FEATURE_SCENES or scene in config.GRADING_SCENES:
        width, height = config.test_resolution(scene)
        return {"width": width, "height": height}
    return {}


def render_ours(scene, integrator, params, spp, seed, processes=None, resolution=None,
                **options):
    """Our render of ``scene`` with ``params`` (film size ``resolution`` if given):
    (mean, variance)."""
    result = render(loaded_scene(scene, params, resolution), integrator, spp=spp, seed=seed,
                    processes=processes, progress=False, **options)
    return result.mean, result.variance


def reference_options(options) -> dict | None:
    """The light-transport options among our render ``options`` (max_depth, rr_depth,
    hide_emitters): the reference is rendered with them too."""
    chosen = {k: v for k, v in (options or {}).items() if k in SCENE_OPTIONS and v is not None}
    return chosen or None


def scene_defaults(scene) -> dict:
    """The scene file's ``<default name=... value=...>`` declarations, {name: value}."""
    return xml_defaults(resolve_scene(scene))


def loaded_scene(scene, params, resolution=None):
    """``pathtracer.load_scene(scene, resolution=..., **params)``, reused while the files are unchanged.

    The convergence test renders a scene up to hundreds of times; loading it (and building
    a mesh's BVH) once saves most of the time on the 82k-triangle scene.
    """
    try:
        content = scene_hash(scene)
    except (OSError, ValueError):
        return load_scene(scene, resolution=resolution, **params)  # the loader reports what is wrong
    return _load_scene_cached(str(scene), content,
                              tuple(sorted((str(k), str(v)) for k, v in params.items())),
                              None if resolution is None else tuple(resolution))


@functools.lru_cache(maxsize=4)
def _load_scene_cached(scene, content, params, resolution):
    return load_scene(scene, resolution=resolution, **dict(params))
