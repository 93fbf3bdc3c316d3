"""Loading a scene file: ``load_scene(path_or_name, resolution=, sample_count=, **params) -> Scene``,
and the one rule from a scene argument (a path or a built-in name) to its file."""
from __future__ import annotations

import os

from ..core.names import suggestion
from .build import build_scene
from .errors import SceneError
from .types import Scene
from .xml import parse_file

BUILTIN_DIR = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "data", "scenes")


def builtin_scene_path(name: str) -> str:
    """Path of the built-in scene ``name`` (``pathtracer/data/scenes/<name>.xml``)."""
    return os.path.join(BUILTIN_DIR, name + ".xml")


def builtin_scene_names() -> list[str]:
    """Names of the built-in scenes: the ``.xml`` files of ``pathtracer/data/scenes``, sorted."""
    if not os.path.isdir(BUILTIN_DIR):
        return []
    return sorted(f[:-4] for f in os.listdir(BUILTIN_DIR) if f.endswith(".xml"))


def is_builtin_name(text: str | os.PathLike) -> bool:
    """Whether ``text`` names a built-in scene rather than a file: no folder, no ``.xml``."""
    text = os.fspath(text)
    return "/" not in text and os.sep not in text and not text.endswith(".xml")


def load_scene(path: str | os.PathLike, resolution: tuple[int, int] | None = None,
               sample_count: int | None = None, **params) -> Scene:
    """Load a Mitsuba 3 XML scene.

    Parameters
    ----------
    path : str or path-like
        An XML file, or the name of a built-in scene (no ``/`` and no
        ``.xml``), e.g. ``"cornell-box"``, looked up in ``pathtracer/data/scenes``.
    resolution : (int, int), optional
        Film (width, height) replacing the file's, literal or ``$param``; the
        ``fov_axis`` keeps its meaning at the new aspect, as in Mitsuba.
    sample_count : int, optional
        Samples per pixel replacing the file's sampler ``sample_count``, literal
        or ``$param``. (``spp=`` is not this keyword: it stays free for the
        ``$spp`` parameter many files use for their sample count.)
    **params
        Values (str, int, float) for ``$name`` placeholders in the file; they
        override the file's ``<default>`` values. A name the file neither
        declares nor uses is an error.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        If the file is malformed or uses something this tracer does not
        render like Mitsuba; the message names the file, line and element.
    """
    file = scene_file(path)
    resolution, sample_count = check_overrides(resolution, sample_count)
    root = parse_file(file, params)
    return build_scene(root, os.fspath(path), os.path.dirname(os.path.abspath(file)),
                       resolution=resolution, spp=sample_count)


def scene_file(path: str | os.PathLike) -> str:
    """The XML file of ``path``: a file path, or a built-in scene name (:func:`is_builtin_name`).

    This is the one rule from a scene argument to its file; the reference side
    (:func:`mitsuba_refs.reference.render.resolve_scene`) uses it too.
    """
    text = os.fspath(path)
    if is_builtin_name(text):
        file = builtin_scene_path(text)
        if not os.path.isfile(file):
            names = builtin_scene_names()
            hint = suggestion(text, names)
            raise SceneError(f"no built-in scene \"{text}\" ({hint}built-in: {', '.join(names) or 'none'}; "
                             "give a path to load a file)")
        return file
    if os.path.isdir(text):
        raise SceneError(f"{text} is a directory, not a scene file")
    if not os.path.isfile(text):
        raise SceneError(f"scene file not found: {text}")
    return text


def check_overrides(resolution, sample_count):
    """Validated ``(resolution, sample_count)`` overrides: ((int, int) or None, int or None)."""
    if resolution is not None:
        try:
            width, height = (int(v) for v in resolution)
        except (TypeError, ValueError):
            raise SceneError(f"resolution must be (width, height), got {resolution!r}") from None
        if width < 1 or height < 1:
            raise SceneError(f"resolution must be positive, got {width}x{height}")
        resolution = (width, height)
    if sample_count is not None:
        if int(sample_count) < 1:
            raise SceneError(f"sample_count must be >= 1, got {sample_count}")
        sample_count = int(sample_count)
    return resolution, sample_count


def parse_resolution(text: str) -> tuple[int, int]:
    """``"64x48"`` -> ``(64, 48)``; ValueError otherwise (for the command lines)."""
    width, sep, height = text.lower().partition("x")
    try:
        if not sep:
            raise ValueError
        size = int(width), int(height)
    except ValueError:
        raise ValueError(f"resolution must look like WIDTHxHEIGHT (e.g. 64x48), got {text!r}") from None
    if min(size) < 1:
        raise ValueError(f"resolution must be positive, got {text!r}")
    return size

