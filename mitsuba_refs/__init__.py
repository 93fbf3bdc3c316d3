"""Reference side of the validation: the shared scene files rendered by
Mitsuba 3, with per-pixel mean and per-sample variance, cached as EXR.

Importing this package does not import Mitsuba: cached references load with
NumPy and OpenEXR only. Main entry points::

    from mitsuba_refs import get_reference, render_reference, choose_variant
"""
from pathtracer import _console  # noqa: F401  (first: a Ctrl-C while the commands start)

from .reference.cache import ReferenceUnavailable, get_reference, reference_key
from .reference.render import Reference, render_reference, resolve_scene
from .reference.variant import choose_variant

__all__ = ["Reference", "ReferenceUnavailable", "choose_variant",
           "get_reference", "reference_key", "render_reference",
           "resolve_scene"]
