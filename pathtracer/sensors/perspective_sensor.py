"""Mitsuba's ``<sensor type="perspective">``: the :class:`Camera` it describes, read with its
film and sampler.

The camera's primary rays are in :mod:`pathtracer.sensors.perspective`, a module of its own:
it is the students' ``camera.py`` (``autograder.skeleton`` copies it), which must not register
the sensor a second time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..scene import transform
from ..scene.properties import Props, children
from ..scene.registry import register
from ..scene.xml import Plugin
from .film import BOX, ReconstructionFilter, build_film
from .sampler import build_sampler


@dataclass
class Camera:
    """Mitsuba's ``perspective`` sensor with an ``hdrfilm``.

    Attributes
    ----------
    to_world : (4, 4) ndarray
        Camera-to-world transform. Camera space looks along +z, +y is up and
        +x is *left* in the image (Mitsuba's convention).
    x_fov : float
        Horizontal field of view in degrees, already converted from the
        ``fov_axis`` given in the file.
    near_clip, far_clip : float
        Clip distances measured along the optical axis.
    width, height : int
        Film resolution in pixels; row 0 is the top of the image.
    rfilter : ReconstructionFilter
        The film's reconstruction filter (:mod:`pathtracer.sensors.film`).
    principal_point : (float, float)
        Mitsuba's ``principal_point_offset_x``/``_y``, in fractions of the film's width and
        height: pixel ``p`` sees what pixel ``p + offset * (W, H)`` would see without it (an
        off-axis frustum, the film moved in its own plane).
    """

    to_world: np.ndarray
    x_fov: float
    near_clip: float = 1e-2
    far_clip: float = 1e4
    width: int = 256
    height: int = 256
    rfilter: ReconstructionFilter = BOX
    principal_point: tuple = (0.0, 0.0)

    #: Mitsuba's plugin name; the other sensors (``orthographic``, ``thinlens``) subclass this.
    kind = "perspective"
    #: Rays from one point through the film (:func:`pathtracer.sensors.perspective.camera_rays`),
    #: the camera light paths connect to (:mod:`pathtracer.sensors.importance`). The other
    #: sensors give their own rays (``sample_rays(pixel, u_film, rng)``).
    pinhole = True


def x_fov_from(fov: float, axis: str, aspect: float) -> float:
    """Horizontal field of view in degrees, following Mitsuba's ``parse_fov``.

    Parameters
    ----------
    fov : float
        The field of view along ``axis``, in degrees.
    axis : {'x', 'y', 'diagonal', 'smaller', 'larger'}
    aspect : float
        Film width / height.
    """
    if axis == "smaller":
        axis = "y" if aspect > 1 else "x"
    elif axis == "larger":
        axis = "x" if aspect > 1 else "y"
    half_tan = np.tan(0.5 * np.deg2rad(fov))
    if axis == "x":
        return float(fov)
    if axis == "y":
        return float(np.rad2deg(2.0 * np.arctan(half_tan * aspect)))
    if axis == "diagonal":
        width = 2.0 * half_tan / np.sqrt(1.0 + 1.0 / (aspect * aspect))
        return float(np.rad2deg(2.0 * np.arctan(0.5 * width)))
    raise ValueError(f"fov_axis must be x, y, diagonal, smaller or larger, not \"{axis}\"")


def film_and_sampler(plugin: Plugin, kids: dict, resolution, spp):
    """``(width, height, rfilter, spp, seed)`` of a sensor's ``<film>`` and ``<sampler>``
    (Mitsuba's defaults where absent), ``resolution`` and ``spp`` replacing the file's."""
    if kids["film"]:
        width, height, rfilter = build_film(kids["film"][0])
    else:   # Mitsuba's default film
        width, height, rfilter = 768, 576, ReconstructionFilter.make("gaussian")
    spp_file, seed = build_sampler(kids["sampler"][0]) if kids["sampler"] else (4, 0)
    if resolution is not None:
        width, height = (int(v) for v in resolution)
    return width, height, rfilter, (spp_file if spp is None else int(spp)), seed


def read_x_fov(plugin: Plugin, props: Props, aspect: float) -> float:
    """The horizontal field of view in degrees from ``fov`` (with ``fov_axis``) or
    ``focal_length``, as Mitsuba's ``parse_fov`` (shared by the perspective and thin-lens
    sensors and the projector)."""
    if props.has("fov") and props.has("focal_length"):
        raise plugin.error("give either fov or focal_length, not both")
    if props.has("fov"):
        fov, axis = props.float("fov", None), props.string("fov_axis", "x").strip().lower()
    else:
        text = props.string("focal_length", "50mm").strip()
        try:
            focal = float(text[:-2] if text.endswith("mm") else text)
        except ValueError:
            raise plugin.error(f"could not parse focal_length \"{text}\" (use e.g. 50mm)",
                               props.line("focal_length")) from None
        # 35 mm film: the focal length fixes the diagonal field of view.
        fov, axis = 2.0 * np.rad2deg(np.arctan(np.hypot(36.0, 24.0) / (2.0 * focal))), "diagonal"
    try:
        x_fov = x_fov_from(fov, axis, aspect)
    except ValueError as e:
        raise plugin.error(str(e), props.line("fov_axis")) from None
    if not 0.0 < x_fov < 180.0:
        raise plugin.error(f"horizontal field of view {x_fov} must lie in (0, 180) degrees")
    return x_fov


def read_clip(plugin: Plugin, props: Props) -> tuple[float, float]:
    """``near_clip`` (1e-2) and ``far_clip`` (1e4), with Mitsuba's ``0 < near < far``."""
    near, far = props.float("near_clip", 1e-2), props.float("far_clip", 1e4)
    if not 0 < near < far:
        raise plugin.error("need 0 < near_clip < far_clip")
    return near, far


def unscaled_to_world(plugin: Plugin, props: Props) -> np.ndarray:
    """The sensor's ``to_world``, refused when it scales (as Mitsuba refuses it)."""
    to_world = props.transform("to_world")
    if transform.has_scale(to_world):
        raise plugin.error("scale factors in the camera's to_world are not allowed (as in Mitsuba)")
    return to_world


def no_principal_point_offset(plugin: Plugin, props: Props) -> None:
    """Refuse a shifted principal point where it is not implemented (the thin lens)."""
    for name in ("principal_point_offset_x", "principal_point_offset_y"):
        if props.float(name, 0.0) != 0.0:
            raise plugin.error(f"{name} is not supported by the {plugin.type} sensor here",
                               props.line(name))


def principal_point_offset(props: Props) -> tuple[float, float]:
    """Mitsuba's ``principal_point_offset_x``/``_y`` (fractions of the film size, default 0)."""
    return (props.float("principal_point_offset_x", 0.0),
            props.float("principal_point_offset_y", 0.0))


SENSOR_CHILDREN = {"film": 1, "sampler": 1, "medium": 1}


@register("sensor", "perspective")
def create(props: Props) -> tuple[Camera, int, int]:
    """The perspective camera, with the film resolution and sampler settings.

    ``props.resolution`` (width, height) and ``props.spp`` replace the file's film size and
    sample count whatever it says; the field of view is then converted with the new
    aspect, as Mitsuba does for a film of that size (``fov_axis`` keeps its meaning).
    """
    frame, spp, seed = read_perspective(props)
    frame["principal_point"] = principal_point_offset(props)
    # A pinhole ignores the focus distance; without motion the shutter is irrelevant.
    props.ignore("focus_distance", "shutter_open", "shutter_close")
    props.finish()
    return Camera(**frame), spp, seed


def read_perspective(props: Props):
    """What every perspective sensor reads (the pinhole's and the thin lens's): ``(frame,
    spp, seed)``, ``frame`` the :class:`Camera` keywords (film, field of view, ``to_world``,
    clip planes); ``props`` is left open for the sensor's own parameters."""
    plugin = props.plugin
    kids = children(plugin, SENSOR_CHILDREN)
    width, height, rfilter, spp, seed = film_and_sampler(plugin, kids, props.resolution, props.spp)
    x_fov = read_x_fov(plugin, props, width / height)
    to_world = unscaled_to_world(plugin, props)
    near, far = read_clip(plugin, props)
    frame = dict(to_world=to_world, x_fov=x_fov, near_clip=near, far_clip=far, width=width,
                 height=height, rfilter=rfilter)
    return frame, spp, seed
