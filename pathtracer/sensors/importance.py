"""The camera as the end of light paths: its importance and the pixel a point projects to.

The inverse of :func:`pathtracer.sensors.perspective.camera_rays`, for the integrators whose paths start
on the lights (light tracing, the t = 1 strategies of BDPT). A pinhole camera's importance
is ``We = 1 / (A cos^3 theta)`` (``A``: the film's area on the camera-space plane z = 1,
theta: the angle to the optical axis): a uniform point on that rectangle has solid-angle
density ``dist^2 / (A cos) = 1 / (A cos^3)``, so ``We`` integrates to 1 over the image. A
point ``p`` seen by the camera contributes ``value * We / |c - p|^2`` to the pixel it
projects to (the pinhole is a Dirac point: no pdf of its own).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .perspective_sensor import Camera


@dataclass
class CameraConnection:
    """Connections from scene points to the pinhole (Mitsuba's ``sample_direction``).

    Attributes
    ----------
    wi : (n, 3) unit direction from the point to the camera.
    dist : (n,) distance to the camera.
    importance : (n,) ``We(-wi) / dist^2``: the camera's importance times the
        geometry term of the pinhole (pdf 1: the pinhole is a Dirac point); 0 where the
        point projects outside the film or lies outside the clip range.
    pixel : (n,) flat index (row * W + column) of the pixel the point projects to, -1 outside.
    film : (n, 2) film position in pixels (x to the right, y down).
    free_dist : (n,) length of the segment from the point towards the camera that must be
        unoccluded: up to the near clip plane, where camera rays start (what lies between
        the pinhole and that plane is not seen, e.g. the wall behind smallpt's camera).
    """

    wi: np.ndarray
    dist: np.ndarray
    importance: np.ndarray
    pixel: np.ndarray
    film: np.ndarray
    free_dist: np.ndarray


def plane_half_extent(camera: Camera) -> tuple[float, float]:
    """Half width and height of the film rectangle on the camera-space plane z = 1."""
    tan_half = np.tan(np.radians(camera.x_fov) / 2)
    return tan_half, tan_half * camera.height / camera.width


def camera_importance(camera: Camera, d_cam: np.ndarray) -> np.ndarray:
    """Importance ``We`` of unit camera-space directions ``d_cam`` (n, 3).

    ``We = 1 / (A cos^3 theta)`` inside the film's field of view, 0 outside, where
    ``A`` is the area of the film rectangle on the plane z = 1: a uniform point on
    that rectangle has solid-angle density ``dist^2 / (A cos) = 1 / (A cos^3)``, so
    ``We`` integrates to 1 over the image (and to ``1 / (W H)`` over one pixel). It
    is also the density with which :func:`pathtracer.sensors.perspective.camera_rays` picks ``d_cam`` (``pdf_camera``).
    """
    half_x, half_y = plane_half_extent(camera)
    cos = d_cam[:, 2]
    safe = np.where(cos > 0, cos, 1.0)
    # The film rectangle's centre on z = 1 (off the axis by the principal point offset).
    centre_x, centre_y = (-2 * half * offset for half, offset in zip((half_x, half_y),
                                                                       camera.principal_point))
    x, y = d_cam[:, 0] / safe - centre_x, d_cam[:, 1] / safe - centre_y
    inside = (cos > 0) & (np.abs(x) <= half_x) & (np.abs(y) <= half_y)
    return np.where(inside, 1.0 / (4.0 * half_x * half_y * safe ** 3), 0.0)


#: The solid-angle pdf of the camera's rays is its importance (pinhole, uniform film sample).
pdf_camera = camera_importance


def connect_to_camera(camera: Camera, p: np.ndarray) -> CameraConnection:
    """Connect world points ``p`` (n, 3) to the pinhole: direction, distance, importance, pixel.

    The inverse of :func:`camera_rays`: a point at camera-space ``(x, y, z)`` lies on the
    ray of film position ``s = ((1 - x / (z tx)) / 2, (1 - y / (z ty)) / 2)`` (``tx, ty``
    the half extents of the film on the plane z = 1). Points closer than the near clip
    plane or beyond the far one are not seen (importance 0).
    """
    linear, origin = camera.to_world[:3, :3], camera.to_world[:3, 3]
    local = (p - origin) @ np.linalg.inv(linear).T
    dist_local = np.linalg.norm(local, axis=1)
    d_cam = local / np.where(dist_local > 0, dist_local, 1.0)[:, None]
    half_x, half_y = plane_half_extent(camera)
    z = np.where(local[:, 2] > 0, local[:, 2], 1.0)
    offset_x, offset_y = camera.principal_point
    s_x = 0.5 * (1.0 - local[:, 0] / (z * half_x)) - offset_x
    s_y = 0.5 * (1.0 - local[:, 1] / (z * half_y)) - offset_y
    inside = ((local[:, 2] >= camera.near_clip) & (local[:, 2] <= camera.far_clip)
              & (s_x >= 0) & (s_x < 1) & (s_y >= 0) & (s_y < 1))
    column = np.minimum((s_x * camera.width).astype(np.int64), camera.width - 1)
    row = np.minimum((s_y * camera.height).astype(np.int64), camera.height - 1)
    to_camera = origin - p
    dist = np.linalg.norm(to_camera, axis=1)
    wi = to_camera / np.where(dist > 0, dist, 1.0)[:, None]
    importance = np.where(inside, camera_importance(camera, d_cam) / np.maximum(dist, 1e-300) ** 2,
                          0.0)
    free_dist = dist * np.maximum(1.0 - camera.near_clip / z, 0.0)
    return CameraConnection(wi, dist, importance, np.where(inside, row * camera.width + column, -1),
                            np.stack((s_x * camera.width, s_y * camera.height), axis=1), free_dist)
