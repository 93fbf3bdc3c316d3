"""Mitsuba's references that some conventions are compared with, fetched or rendered.

A few differences of convention cannot be undone on the test image; Mitsuba renders the
scene in that convention instead (:mod:`mitsuba_refs.verdicts.conventions` compares):

* one bounce too few: the reference at ``max_depth - 1``;
* another reconstruction filter: copies of the file with a gaussian or tent filter;
* another field-of-view axis: copies with each other ``fov_axis``;
* pixel samples at the pixel centre: Mitsuba's image of the pixel centres
  (:func:`centre_references`, :mod:`mitsuba_refs.reference.centres`);
* half a pixel, exactly: a copy whose principal point is moved by half a pixel
  (:func:`half_shift_references`; the test's own image moved by averaging neighbours is
  only right where the radiance is linear across two pixels).

Each fetcher returns ``[(value, reference), ...]``. A copy is written to
``<temp>/mitsuba-refs-conventions`` and named by its content, so that its reference is
found in the cache next time; only a file that reads no other file is copied.
"""
from __future__ import annotations

import hashlib
import importlib.util
import re
import tempfile
from pathlib import Path

from pathtracer.scene.xml_files import scene_files

from ..errors import ReferenceUnavailable, RefsInputError
from ..reference.cache import get_reference
from ..reference.centres import centre_spp, render_centres
from ..reference.render import resolve_scene
from .scenes import reference_options, scene_defaults

__all__ = ["BOX_FILTER", "OTHER_FILTERS", "FOV_AXES", "MAX_RENDERED_PIXELS",
           "COPY_REFERENCE_SPP", "fewer_bounces_reference", "filtered_references",
           "fov_axis_references", "centre_references", "half_shift_references", "optional",
           "may_render", "effective_axis"]

#: The film filter the references with another one replace, and those they try instead (the
#: filters whose references Mitsuba renders here: mitsuba_refs.reference.filtered).
BOX_FILTER = '<rfilter type="box"/>'
OTHER_FILTERS = ("gaussian", "tent")
#: What Mitsuba's ``fov_axis`` can mean on a film (``smaller`` and ``larger`` are one of x, y).
FOV_AXES = ("x", "y", "diagonal")
#: References a convention needs are rendered (when not cached) only for films of at most
#: this many pixels: a 4096-spp reference of 64 x 64 takes 10-14 s here, one of 512 x 512
#: 64 times as long, too much to spend on a guess; larger films use cached ones only.
MAX_RENDERED_PIXELS = 128 * 128
#: Samples per pixel of the references of a file's copies: a quarter of a committed
#: reference's, a quarter of the time. The mean test counts the reference's noise, so it
#: stays valid; against a 64-spp test its standard error grows by 2 %
#: (sqrt((1 + 1/16) / (1 + 1/64))).
COPY_REFERENCE_SPP = 1024
#: The perspective sensor's opening tag, for a copy with a moved principal point.
_PERSPECTIVE = re.compile(r'<sensor\s+type="perspective"[^>]*>')


def may_render(reference) -> bool:
    """Whether a reference of this film may be rendered for a convention
    (:data:`MAX_RENDERED_PIXELS`)."""
    height, width = reference.mean.shape[:2]
    return height * width <= MAX_RENDERED_PIXELS


def fewer_bounces_reference(scene, params, settings, reference, log=None):
    """``[(depth - 1, Mitsuba's reference at max_depth depth - 1)]`` when the reference's
    path length ``depth`` is bounded and at least 2, else empty. The depth reaches Mitsuba
    as the file's ``max_depth`` parameter where it declares one (the committed per-bounce
    references), else as an override (a render of the reference when it is not cached)."""
    depth = int((reference.metadata.get("mitsuba_integrator") or {}).get("max_depth", -1))
    if depth < 2:
        return []
    overrides = dict(reference_options(settings.options) or {})
    depth_params = dict(params)
    if "max_depth" in scene_defaults(scene):
        overrides.pop("max_depth", None)
        depth_params["max_depth"] = depth - 1
    else:
        overrides["max_depth"] = depth - 1
    shorter = get_reference(scene, depth_params, settings.reference, log=log,
                            options=overrides or None, resolution=settings.resolution,
                            render=may_render(reference))
    return [(depth - 1, shorter)]


def _file_copies(scene, old: str, news) -> list:
    """Copies of the scene file with its one ``old`` text replaced by each of ``news``:
    ``[(new, path), ...]``, named by their content. Empty when the file holds ``old``
    other than once, or reads other files (a copy elsewhere could not)."""
    path = resolve_scene(scene)
    text = path.read_text()
    if text.count(old) != 1 or scene_files(str(path)):
        return []
    folder = Path(tempfile.gettempdir()) / "mitsuba-refs-conventions"
    folder.mkdir(parents=True, exist_ok=True)
    copies = []
    for new in news:
        changed = text.replace(old, new)
        digest = hashlib.sha256(changed.encode()).hexdigest()[:12]
        copy = folder / f"{path.stem}-{digest}.xml"
        if not copy.exists():
            copy.write_text(changed)
        copies.append((new, copy))
    return copies


def _copied_references(copies, values, params, settings, reference, log):
    """``[(value, Mitsuba's reference of the copy)]`` at :data:`COPY_REFERENCE_SPP`."""
    return [(value, get_reference(str(copy), params, settings.reference,
                                  spp=COPY_REFERENCE_SPP, log=log,
                                  options=reference_options(settings.options),
                                  resolution=settings.resolution, render=may_render(reference)))
            for value, (_, copy) in zip(values, copies)]


def filtered_references(scene, params, settings, reference, log=None) -> list:
    """Mitsuba's references of copies of the file with each of :data:`OTHER_FILTERS` in
    place of its box filter. Only for a file whose film has exactly ``<rfilter
    type="box"/>`` and that reads no other file."""
    copies = _file_copies(scene, BOX_FILTER, [f'<rfilter type="{kind}"/>' for kind in OTHER_FILTERS])
    return _copied_references(copies, OTHER_FILTERS, params, settings, reference, log)


def centre_references(scene, params, settings, reference, log=None) -> list:
    """``[(None, image)]``: Mitsuba's image of the pixel centres
    (:func:`mitsuba_refs.reference.centres.render_centres`, rendered each time: it is not
    cached). Only for a box-filtered reference of at most :data:`MAX_RENDERED_PIXELS`."""
    spec = (getattr(reference, "metadata", None) or {}).get("rfilter") or {"type": "box"}
    if spec.get("type") != "box" or not may_render(reference):
        return []
    if importlib.util.find_spec("mitsuba") is None:
        raise ReferenceUnavailable("Mitsuba is not installed: no image of the pixel centres")
    height, width = reference.mean.shape[:2]
    if log is not None:
        log(f"conventions: Mitsuba renders its image of the pixel centres "
            f"({centre_spp(width, height)} spp, one Python call per sample)")
    try:
        image = render_centres(scene, params, settings.reference,
                               options=reference_options(settings.options),
                               resolution=settings.resolution)
    except ValueError as refused:
        raise RefsInputError(str(refused)) from None
    return [(None, image)]


def half_shift_references(scene, params, settings, reference, direction, log=None) -> list:
    """``[((dy / 2, dx / 2), reference)]``: Mitsuba's image moved by half a pixel in
    ``direction`` = (dy, dx), a copy of the file whose perspective sensor has its principal
    point moved by half a pixel the other way (the film, not the image, moves). Only for a
    file with one perspective sensor and no principal point offset, that reads no other
    file."""
    text = resolve_scene(scene).read_text()
    tags = _PERSPECTIVE.findall(text)
    if len(tags) != 1 or "principal_point_offset" in text:
        return []
    height, width = reference.mean.shape[:2]
    dy, dx = direction
    offsets = (f'<float name="principal_point_offset_x" value="{-dx * 0.5 / width!r}"/>'
               f'<float name="principal_point_offset_y" value="{-dy * 0.5 / height!r}"/>')
    copies = _file_copies(scene, tags[0], [tags[0] + offsets])
    return _copied_references(copies, [(dy / 2, dx / 2)], params, settings, reference, log)


def effective_axis(axis: str, width: int, height: int) -> str:
    """``x``, ``y`` or ``diagonal``: what Mitsuba's ``fov_axis`` means on this film."""
    if axis == "smaller":
        return "x" if width <= height else "y"
    if axis == "larger":
        return "x" if width >= height else "y"
    return axis


def fov_axis_references(scene, params, settings, reference, log=None) -> list:
    """Mitsuba's references of copies of the file whose one ``fov_axis`` is each axis that
    means something else on this film (x, y, diagonal; x and y are the same on a square
    film). Only for a file with exactly one ``<string name="fov_axis" .../>`` that reads no
    other file."""
    text = resolve_scene(scene).read_text()
    found = re.findall(r'<string name="fov_axis" value="(\w+)"/>', text)
    if len(found) != 1:
        return []
    height, width = reference.mean.shape[:2]
    own = effective_axis(found[0], width, height)
    others = [axis for axis in FOV_AXES if axis != own
              and not (width == height and {axis, own} == {"x", "y"})]
    old = f'<string name="fov_axis" value="{found[0]}"/>'
    copies = _file_copies(scene, old, [f'<string name="fov_axis" value="{a}"/>' for a in others])
    return _copied_references(copies, others, params, settings, reference, log)


def optional(fetch, result, settings, reference, log, **where):
    """The references a convention needs (``fetch``; ``where`` passed on), or ``[]`` when
    they cannot be had (no Mitsuba and nothing cached, a film larger than
    :data:`MAX_RENDERED_PIXELS` and nothing cached, a cache that cannot be written, a film
    Mitsuba's variant cannot filter): the convention is then not tried, and the verdicts
    stand as they are."""
    try:
        return fetch(result.scene, result.params, settings, reference, log=log, **where)
    except (ReferenceUnavailable, RefsInputError) as missing:
        if log is not None:
            log(f"conventions: not tried ({str(missing).splitlines()[0]})")
        return []
