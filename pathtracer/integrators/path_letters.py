r"""Heckbert letters of a scene's BSDFs, and the path classes' automata over one scene.

:mod:`pathtracer.core.pathclasses` compiles a class expression (``LS+DE``) over the letters
L, D, S, G, E; this module gives each BSDF of a scene its letter, and follows light and
camera subpaths of that scene through a class's automata (light tracing and BDPT select
the paths of a class with it, :mod:`.class_selection`).

Glossy surfaces
---------------
:func:`bsdf_letters` gives each BSDF of a scene its letter. With
``glossy='G'`` (default) a rough conductor is its own letter ``G``. With
``glossy`` a number t, a rough conductor whose (mean) roughness alpha <= t
counts as ``S`` (a sharp, nearly mirror-like lobe) and one with alpha > t
as ``D``; ``glossy='D'`` or ``'S'`` folds every glossy surface into that
letter. ``twosided`` takes the letter of its nested BSDF; an unknown BSDF is
``S`` if it is purely Dirac, else ``D``.
"""
from __future__ import annotations

import numpy as np

from ..bsdfs import Conductor, Dielectric, Diffuse, RoughConductor, RoughDielectric, RoughPlastic, TwoSided
from ..core.pathclasses import LETTER, compile_joined


def bsdf_letter(bsdf, glossy="G") -> str:
    """Heckbert letter of one BSDF object (see the module docstring for ``glossy``)."""
    if isinstance(bsdf, TwoSided):
        return bsdf_letter(bsdf.nested, glossy)
    if isinstance(bsdf, Diffuse):
        return "D"
    if isinstance(bsdf, (Conductor, Dielectric)):
        return "S"
    if isinstance(bsdf, (RoughConductor, RoughDielectric, RoughPlastic)):
        if isinstance(glossy, str):
            if glossy.upper() not in ("G", "D", "S"):
                raise ValueError(f"glossy must be 'G', 'D', 'S' or an alpha threshold, got {glossy!r}")
            return glossy.upper()
        alpha = _roughness(bsdf)
        return "S" if alpha <= float(glossy) else "D"
    return "S" if getattr(bsdf, "is_delta", False) else "D"


def _roughness(bsdf) -> float:
    """Mean microfacet roughness of a rough BSDF (geometric mean of alpha_u, alpha_v)."""
    for owner in (bsdf, getattr(bsdf, "distribution", None), getattr(bsdf, "mf", None)):
        if owner is not None and hasattr(owner, "alpha_u"):
            # A textured roughness counts with its mean.
            alpha_u, alpha_v = (getattr(a, "mean", lambda a=a: a)()
                                for a in (owner.alpha_u, owner.alpha_v))
            return float(np.sqrt(alpha_u * alpha_v))
    for value in vars(bsdf).values():
        if hasattr(value, "alpha_u"):
            return float(np.sqrt(value.alpha_u * value.alpha_v))
    raise ValueError(f"cannot find the roughness of {bsdf!r}")


def bsdf_letters(scene, glossy="G") -> np.ndarray:
    """Letter code (index into :data:`ALPHABET`) of every BSDF of ``scene``."""
    return np.array([LETTER[bsdf_letter(b, glossy)] for b in scene.bsdfs], dtype=np.int32)


class SubpathClass:
    """A :class:`JoinedClass` with the letters of one scene: the automaton states of the
    subpaths of light tracing and BDPT, one per path, updated a vertex at a time.

    Parameters
    ----------
    expression : str
        The class, light first (``"LS+DE"``).
    scene : Scene
        Gives each shape the letter of its BSDF (:func:`bsdf_letters`).
    glossy : {'G', 'D', 'S'} or float
        As for :func:`bsdf_letter`.
    """

    def __init__(self, expression: str, scene, glossy="G"):
        self.joined = compile_joined(expression)
        self.shape_letter = bsdf_letters(scene, glossy)[np.asarray(scene.shape_bsdf)]
        self.after_light = int(self.joined.light_step(self.joined.start, "L"))
        self.after_eye = int(self.joined.camera_step(self.joined.camera.start, "E"))

    def light_states(self, count: int) -> np.ndarray:
        """(count,) states of light subpaths that hold their light vertex only."""
        return np.full(count, self.after_light, dtype=np.int32)

    def camera_states(self, count: int) -> np.ndarray:
        """(count,) states of camera subpaths that hold the eye only."""
        return np.full(count, self.after_eye, dtype=np.int32)

    def light_vertex(self, state: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Light-side states after a scattering vertex on each of ``shape``."""
        return self.joined.light_step(state, self.shape_letter[shape])

    def camera_vertex(self, state: np.ndarray, shape: np.ndarray) -> np.ndarray:
        """Camera-side states after a scattering vertex on each of ``shape``."""
        return self.joined.camera_step(state, self.shape_letter[shape])

    def accepts(self, light_state, camera_state) -> np.ndarray:
        """Whether the joined subpaths form a path of the class."""
        return self.joined.accepts(light_state, camera_state)


def describe_letters(scene, glossy="G") -> list[str]:
    """'name: letter' for each BSDF of the scene, for reports."""
    return [f"{type(b).__name__}"
            + (f"({type(b.nested).__name__})" if hasattr(b, "nested") else "")
            + f" -> {bsdf_letter(b, glossy)}" for b in scene.bsdfs]


def parse_glossy(value):
    """'G' / 'D' / 'S' stay letters; anything numeric becomes a float threshold."""
    if isinstance(value, (int, float)):
        return float(value)
    try:
        return float(value)
    except ValueError:
        return str(value).upper()
