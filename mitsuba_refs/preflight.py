"""Checks of the command line's input made before anything is rendered.

A reference takes minutes to render; a bad scene path, an undeclared ``-D``
name, an option out of range or an image too small for the tests must be
refused at once, in one line that says what to change
(:class:`~mitsuba_refs.errors.RefsInputError`).
"""

import math
import os
from pathlib import Path

from pathtracer.core.names import suggestion
from pathtracer.scene.load import builtin_scene_names

from .errors import RefsInputError
from .reference.cache import parse_xml, scene_hash
from .reference.render import check_film_filter, resolve_scene, split_params

#: Edge of the tiles of the mean and variance tests (mitsuba_refs.stats), and the fewest
#: tiles the variance test accepts.
TILE = 8
MIN_TILES = 8


def scene_path(scene):
    """The file of ``scene`` (a path or a built-in name), or a one-line error."""
    path = Path(scene)
    if path.is_dir():
        raise RefsInputError(f"{scene}: is a folder, not a scene file")
    try:
        found = resolve_scene(scene)
    except FileNotFoundError:
        found = path if path.exists() else None    # "notes.txt" reads as a built-in name
    if found is None:
        builtin = ", ".join(builtin_scene_names())
        hint = suggestion(str(scene), builtin_scene_names())
        raise RefsInputError(f"{scene}: no such file, and not a built-in scene ({hint}{builtin})")
    if found.suffix != ".xml":
        raise RefsInputError(f"{scene}: a scene file must end in .xml")
    return found


def check_scene(scene, params):
    """Check a scene file and the parameters given for it without Mitsuba.

    The file must exist and be well-formed, its included files must exist,
    every name in ``params`` must be declared by the file (``<default>`` or
    ``$name``), and every film must use a filter both renderers implement
    (box, tent, gaussian).

    Returns
    -------
    Path
        The scene file.

    Raises
    ------
    RefsInputError, pathtracer.SceneError
        Saying what is wrong, naming the file (and line where known).
    """
    path = scene_path(scene)
    parse_xml(path)
    # A -D the file does not declare: the tracer loader's SceneError, naming file and line.
    split_params(path, {str(k): str(v) for k, v in (params or {}).items()})
    scene_hash(path)
    try:
        check_film_filter(path)
    except ValueError as error:
        raise RefsInputError(str(error)) from None
    return path


def check_spp(spp, option="--spp"):
    """Refuse fewer than two samples per pixel: a per-pixel variance needs two."""
    if spp < 2:
        raise RefsInputError(f"{option} must be >= 2 (a per-pixel variance needs two samples), "
                             f"got {spp}")


def check_ladder(ladder):
    """The convergence ladder: at least three increasing sample counts >= 1."""
    if len(ladder) < 3 or any(b <= a for a, b in zip(ladder, ladder[1:])) or ladder[0] < 1:
        shown = ",".join(map(str, ladder))
        raise RefsInputError(f"--ladder needs at least 3 increasing sample counts >= 1 "
                             f"(e.g. 1,4,16,64), got {shown}")


def check_image_size(width, height, scene):
    """Refuse an image with fewer than :data:`MIN_TILES` tiles of ``TILE`` x ``TILE`` pixels."""
    tiles = math.ceil(width / TILE) * math.ceil(height / TILE)
    if tiles < MIN_TILES:
        raise RefsInputError(
            f"{scene}: the image is {width}x{height} pixels, {tiles} tile(s) of {TILE}x{TILE}; "
            f"the tests need at least {MIN_TILES} tiles: render at least 32x16 pixels "
            f"(--resolution 32x32, or -D width=32 -D height=32 if the file declares them)")


def check_output_folder(folder, option="--out"):
    """Refuse an output folder that could not be created or written, before any work:
    an existing file, a path under a file, or a folder without write permission."""
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise RefsInputError(f"{option} {folder}: is a file, not a folder")
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise RefsInputError(f"{option} {folder}: {existing} is a file, so the folder "
                             f"cannot be created")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise RefsInputError(f"{option} {folder}: {existing} is not writable")


def check_output_file(file, option):
    """Refuse an output file that could not be written, before any work: a folder at its
    path, a parent that is a file, or a folder that is not writable (the file is written
    under a temporary name there and renamed)."""
    path = Path(file)
    if path.is_dir():
        raise RefsInputError(f"{option} {file}: is a folder, not a file")
    existing = path.parent
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise RefsInputError(f"{option} {file}: {existing} is a file, so {file} cannot be created")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise RefsInputError(f"{option} {file}: {existing} is not writable")
