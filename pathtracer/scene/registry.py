"""One registry of plugins per kind: what a scene file may name, and what builds it.

A plugin registers the function that builds it from its element beside its class (pbrt's
``Create``, Mitsuba's constructor from ``Properties``)::

    @register("bsdf", "diffuse")
    def create(props):
        return Diffuse(props.reflectance_or_texture("reflectance", 0.5))

The loader (:mod:`pathtracer.scene.build`) imports every plugin package, so that each
module has registered itself, and looks the element's type up here; the list of
supported plugins in its error messages, ``pathtracer.INTEGRATORS``, the harness's
splatting integrators and the command lines' choices are all read from these tables.
Every factory takes one argument, the element's :class:`~pathtracer.scene.properties.Props`:
the element is ``props.plugin``, and what a kind needs besides (where files are looked up,
the textures built so far, the shape's index and transform, a sensor's film size) is set
there by the loader. An integrator registers its class instead, which the renderer
instantiates with its options.
"""
from __future__ import annotations

from typing import Callable

#: The plugin kinds of a Mitsuba 3 scene file that this tracer builds.
KINDS = ("bsdf", "texture", "shape", "emitter", "sensor", "film", "rfilter", "sampler",
         "medium", "phase", "volume", "integrator")

_FACTORIES: dict[str, dict[str, Callable]] = {kind: {} for kind in KINDS}


def register(kind: str, *names: str):
    """Decorator: the decorated factory builds the plugins ``names`` of ``kind``.

    Raises
    ------
    ValueError
        For an unknown kind, or a name already registered (two plugins claiming one
        name would make the loader's choice depend on import order).
    """
    if kind not in _FACTORIES:
        raise ValueError(f"unknown plugin kind {kind!r} (kinds: {', '.join(KINDS)})")

    def decorate(factory):
        for name in names:
            if name in _FACTORIES[kind]:
                raise ValueError(f"{kind} plugin {name!r} is registered twice")
            _FACTORIES[kind][name] = factory
        return factory
    return decorate


def factory(kind: str, name: str) -> Callable | None:
    """The factory of plugin ``name`` of ``kind``, or None when none is registered."""
    return _FACTORIES[kind].get(name)


def names(kind: str) -> tuple[str, ...]:
    """The registered plugin names of ``kind``, in registration order."""
    return tuple(_FACTORIES[kind])
