"""The ``paths`` option of the integrators that grow paths from the lights: one Heckbert class.

``light`` and ``bdpt`` take ``paths="LS+DE"`` (and ``glossy``, the letter of glossy BSDFs):
their subpaths carry the states of the class's automata (:class:`pathtracer.integrators.path_letters.SubpathClass`)
and every contribution of a path outside the class is dropped. The path tracer's classes are
:mod:`pathtracer.integrators.pathclass`, which renders several classes in one pass.
"""
from __future__ import annotations

from ..core.pathclasses import compile_joined
from .path_letters import SubpathClass, parse_glossy


class ClassSelection:
    """The ``paths`` option of the integrators that grow paths from the lights (``light``,
    ``bdpt``): keep only the contributions of paths in one Heckbert class.

    Call :meth:`select_paths` from ``__init__``; :meth:`subpath_class` gives the class
    with one scene's letters (None: every path counts). The random numbers do not depend
    on the class, so with the same seed a partition's images add up to the full render.
    """

    paths = None
    glossy = "G"

    def select_paths(self, paths: str | None, glossy="G") -> None:
        """Set the class (an expression, light first, or None) and the glossy letter."""
        self.paths = paths or None
        self.glossy = parse_glossy(glossy)
        if self.paths is not None:
            compile_joined(self.paths)      # a malformed expression fails here, not mid-render

    def subpath_class(self, scene) -> SubpathClass | None:
        """The selected class with ``scene``'s letters, or None when there is none."""
        return None if self.paths is None else SubpathClass(self.paths, scene, self.glossy)

    def class_options(self) -> dict:
        """The class options for :meth:`Integrator.options` (empty when none is selected)."""
        return {} if self.paths is None else dict(paths=self.paths, glossy=self.glossy)
