"""The Cornell-box subset of Mitsuba 3 XML as plain arrays, ready for Blender (no ``bpy`` here).

:func:`translate` reads a scene file with the project's parser
(:func:`pathtracer.scene.xml.parse_file`: includes, ``<default>``, ``$name`` parameters,
transforms) and returns a :class:`SceneDesc`: world-space triangle meshes with their
material and emission, the camera as a Blender camera matrix and horizontal field of view,
the film and the path length. ``render.py`` builds the Blender scene from it. Anything
outside the subset raises :class:`SubsetError`, whose text is one line naming the file,
line and plugin.

The subset: shapes ``rectangle``, ``cube``, ``obj``, ``ply`` with ``to_world`` (and
``flip_normals``, ``face_normals``); BSDFs ``diffuse`` (RGB or grey ``reflectance``) and
``twosided`` around one ``diffuse``; ``area`` emitters (RGB or grey ``radiance``); a
``constant`` environment; the ``perspective`` sensor (``fov`` with ``fov_axis``,
``to_world``, clip planes), ``hdrfilm`` with a ``box`` filter; the ``path`` integrator.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field

import numpy as np

from pathtracer.io.meshes import MeshFormatError, read_obj, read_ply, smooth_vertex_normals
from pathtracer.scene.errors import SceneError
from pathtracer.scene.xml import Plugin, parse_file
from pathtracer.sensors.perspective_sensor import x_fov_from

#: Mitsuba's camera space (+x the image's left, +y up, looking along +z) to Blender's
#: (+x right, +y up, looking along -z).
MITSUBA_TO_BLENDER_CAMERA = np.diag([-1.0, 1.0, -1.0, 1.0])
#: Samplers whose only effect is the noise: their sample_count and seed are read.
SAMPLERS = {"independent", "stratified", "multijitter", "orthogonal", "ldsampler"}
#: Film properties that do not change the expected image.
FILM_FORMAT_PROPS = {"pixel_format", "component_format", "file_format"}


class SubsetError(SceneError):
    """A scene element outside the subset this example translates."""


@dataclass
class Mesh:
    """One shape as world-space triangles with its material.

    Attributes
    ----------
    name : str
        The shape's id, or its type and line.
    positions : (V, 3) float64
        World-space vertices.
    faces : (F, 3) int64
        Triangles, counter-clockwise seen from the front (Blender's face normal is Mitsuba's).
    normals : (V, 3) float64 or None
        World-space shading normals per vertex (smooth shading), or None for flat faces.
    reflectance : (3,) float64
        Diffuse albedo, linear RGB.
    twosided : bool
        The back side reflects like the front (``twosided``); else it is black, as
        Mitsuba's one-sided BSDFs.
    radiance : (3,) float64 or None
        Radiance of an ``area`` emitter, emitted from the front side only.
    """

    name: str
    positions: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None
    reflectance: np.ndarray
    twosided: bool = False
    radiance: np.ndarray | None = None


@dataclass
class Camera:
    """A pinhole camera for Blender.

    Attributes
    ----------
    matrix : (4, 4) float64
        Blender camera-to-world: a rotation (unit, orthogonal columns, determinant +1) and
        the eye; the camera looks along its -z with +y up and +x to the image's right.
    x_fov : float
        Horizontal field of view in degrees (Blender's ``sensor_fit = 'HORIZONTAL'``).
    near_clip, far_clip : float
        Clip distances along the optical axis (Mitsuba and Cycles both clip planes).
    mirrored : bool
        Mitsuba's ``to_world`` mirrors (determinant < 0): the image must be flipped left to
        right after rendering with ``matrix``, whose x column was negated.
    file_fov : float
        The file's ``fov`` as written, along its ``fov_axis`` (for ``--deviate fov-axis``).
    """

    matrix: np.ndarray
    x_fov: float
    near_clip: float = 1e-2
    far_clip: float = 1e4
    mirrored: bool = False
    file_fov: float = 0.0


@dataclass
class SceneDesc:
    """Everything ``render.py`` needs to build and render the Blender scene."""

    file: str
    camera: Camera
    width: int
    height: int
    spp: int
    seed: int
    max_depth: int
    meshes: list[Mesh] = field(default_factory=list)
    background: np.ndarray | None = None


# ---- small pure helpers -----------------------------------------------------------------

def blender_camera(to_world: np.ndarray) -> tuple[np.ndarray, bool]:
    """Blender camera-to-world matrix of a Mitsuba sensor ``to_world``, and whether it mirrors.

    Mitsuba's camera looks along its local +z with +x to the image's *left*; Blender's looks
    along -z with +x to the right, so ``B = to_world @ diag(-1, 1, -1)``. A mirroring
    ``to_world`` (determinant < 0, e.g. a ``scale x="-1"`` before a ``lookat``) gives a ``B``
    Blender cannot hold as a rotation: its x column is negated and the caller flips the
    rendered image left to right, which is the same picture. Scale is removed (Mitsuba
    normalises ray directions); a shear or non-uniform scale is refused (ValueError).
    """
    m = np.asarray(to_world, dtype=float) @ MITSUBA_TO_BLENDER_CAMERA
    linear = m[:3, :3]
    norms = np.linalg.norm(linear, axis=0)
    if np.any(norms <= 0) or np.ptp(norms) > 1e-6 * norms.max():
        raise ValueError("the sensor's to_world scales its axes differently")
    unit = linear / norms
    if np.max(np.abs(unit.T @ unit - np.eye(3))) > 1e-6:
        raise ValueError("the sensor's to_world is not a rotation (sheared axes)")
    mirrored = bool(np.linalg.det(unit) < 0)
    if mirrored:
        unit[:, 0] = -unit[:, 0]
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = unit, m[:3, 3]
    return out, mirrored


def lens_for_fov(x_fov: float, sensor_width: float = 36.0) -> float:
    """Blender focal length (mm) giving the horizontal field of view ``x_fov`` (degrees)."""
    return 0.5 * sensor_width / np.tan(0.5 * np.deg2rad(x_fov))


def cycles_bounces(max_depth: int, unlimited: int = 1024) -> int:
    """Cycles' ``max_bounces`` for Mitsuba's ``max_depth`` (>= 2).

    Mitsuba counts path segments: 1 sees emission, 2 adds direct lighting. Cycles counts
    scattering events after the first hit: 0 bounces is direct lighting. So bounces =
    max_depth - 2; Mitsuba's -1 (unbounded, Russian roulette) becomes ``unlimited``, Cycles'
    largest setting (a path of 1024 diffuse bounces in a box of albedo below 0.9 carries less
    than 1e-46 of the light).
    """
    if max_depth < 0:
        return unlimited
    if max_depth < 2:
        raise ValueError("max_depth 0 and 1 have no Cycles bounce count (render.py blackens "
                         "the BSDFs instead)")
    return max_depth - 2


def cycles_seed(seed: int) -> int:
    """Cycles' ``seed`` (0 to 2^31 - 1) for the harness's 32-bit seed: its low 31 bits."""
    return int(seed) & 0x7FFFFFFF


def rectangle(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-space corners and two triangles of Mitsuba's ``rectangle`` ([-1, 1]^2, z = 0).

    The front is where the normal ``(0, 0, 1)`` goes under the inverse transpose of
    ``to_world``, as Mitsuba's rectangle has it even when ``to_world`` mirrors; the winding is
    chosen to agree with it.
    """
    local = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], dtype=float)
    positions = _points(to_world, local)
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    normal = _normals(to_world, np.array([[0.0, 0.0, 1.0]]))[0]
    return positions, _orient(positions, faces, np.repeat(normal[None], 2, axis=0))


def cube(to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-space corners and twelve triangles of Mitsuba's ``cube`` ([-1, 1]^3).

    Four corners per face (flat faces), each face counter-clockwise seen from where its
    outward normal goes under the inverse transpose of ``to_world``.
    """
    corners, faces, normals = [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = np.zeros(3)
            n[axis] = sign
            u = np.zeros(3)
            u[(axis + 1) % 3] = 1.0
            v = np.cross(n, u)
            base = len(corners)
            corners += [n - u - v, n + u - v, n + u + v, n - u + v]
            faces += [[base, base + 1, base + 2], [base, base + 2, base + 3]]
            normals += [n, n]
    positions = _points(to_world, np.array(corners))
    world_n = _normals(to_world, np.array(normals))
    return positions, _orient(positions, np.array(faces), world_n)


def _points(m: np.ndarray, p: np.ndarray) -> np.ndarray:
    return p @ m[:3, :3].T + m[:3, 3]


def _normals(m: np.ndarray, n: np.ndarray) -> np.ndarray:
    out = n @ np.linalg.inv(m[:3, :3])      # rows times the inverse transpose
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def _orient(positions: np.ndarray, faces: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """``faces`` with the winding of each triangle reversed where it disagrees with ``normals``."""
    p = positions[faces]
    geometric = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.einsum("ij,ij->i", geometric, normals) < 0
    out = faces.copy()
    out[flip] = out[flip][:, ::-1]
    return out


# ---- the XML tree -----------------------------------------------------------------------

class _Props:
    """Properties of one plugin, each read at most once; any left unread is refused."""

    def __init__(self, plugin: Plugin):
        self.plugin = plugin
        self.unread = set(plugin.props)

    def get(self, name: str, tags: tuple[str, ...], default=None):
        prop = self.plugin.props.get(name)
        if prop is None:
            return default
        self.unread.discard(name)
        if prop.tag not in tags:
            raise self.error(f"property \"{name}\" must be {' or '.join(tags)}, not <{prop.tag}>",
                             prop.line)
        return prop.value

    def color(self, name: str, default: float) -> np.ndarray:
        value = self.get(name, ("rgb", "float", "integer"), default)
        return np.broadcast_to(np.asarray(value, dtype=float), (3,)).copy()

    def error(self, message: str, line: int | None = None) -> SubsetError:
        return _error(self.plugin, message, line)

    def finish(self) -> None:
        if self.unread:
            name = sorted(self.unread, key=lambda n: self.plugin.props[n].line)[0]
            raise self.error(f"property \"{name}\" is outside the subset this example translates",
                             self.plugin.props[name].line)


def _error(plugin: Plugin, message: str, line: int | None = None) -> SubsetError:
    return SubsetError(message, plugin.file, plugin.line if line is None else line, plugin.label)


def _refuse(plugin: Plugin) -> SubsetError:
    return _error(plugin, f"{plugin.kind} type \"{plugin.type}\" is outside the subset (shapes "
                  "rectangle, cube, obj, ply; bsdfs diffuse, twosided; emitters area, constant; "
                  "sensor perspective; film hdrfilm; rfilter box; integrator path)")


def _children(plugin: Plugin, kind: str) -> list[Plugin]:
    return [c for c in plugin.children if c.kind == kind]


def _only_children(plugin: Plugin, allowed: set[str]) -> None:
    for child in plugin.children:
        if child.kind not in allowed:
            raise _error(child, f"a <{child.kind}> inside {plugin.label} is outside the subset")


def _material(plugin: Plugin | None) -> tuple[np.ndarray, bool]:
    """(reflectance, twosided) of a ``diffuse`` or ``twosided`` BSDF; Mitsuba's default
    (diffuse, 0.5) when the shape has none."""
    if plugin is None:
        return np.full(3, 0.5), False
    if plugin.type == "twosided":
        inner = _children(plugin, "bsdf")
        _Props(plugin).finish()
        if len(inner) != 1 or inner[0].type != "diffuse":
            raise _error(plugin, "twosided is translated around exactly one diffuse BSDF")
        return _material(inner[0])[0], True
    if plugin.type != "diffuse":
        raise _refuse(plugin)
    _only_children(plugin, set())
    props = _Props(plugin)
    reflectance = props.color("reflectance", 0.5)
    props.finish()
    return reflectance, False


def _emitter(plugin: Plugin) -> np.ndarray:
    """Radiance of an ``area`` or ``constant`` emitter (Mitsuba's default: 1)."""
    if plugin.type not in ("area", "constant"):
        raise _refuse(plugin)
    _only_children(plugin, set())
    props = _Props(plugin)
    radiance = props.color("radiance", 1.0)
    props.finish()
    return radiance


def _shape(plugin: Plugin, folders: list[str]) -> Mesh:
    """One ``rectangle``, ``cube``, ``obj`` or ``ply`` as a :class:`Mesh`."""
    if plugin.type not in ("rectangle", "cube", "obj", "ply"):
        raise _refuse(plugin)
    _only_children(plugin, {"bsdf", "emitter"})
    props = _Props(plugin)
    to_world = props.get("to_world", ("transform",), np.eye(4))
    flip = props.get("flip_normals", ("boolean",), False)
    normals = None
    if plugin.type == "rectangle":
        positions, faces = rectangle(to_world)
    elif plugin.type == "cube":
        positions, faces = cube(to_world)
    else:
        positions, faces, normals = _mesh_file(plugin, props, to_world, folders)
    props.finish()
    if flip:
        faces = faces[:, ::-1].copy()
        normals = None if normals is None else -normals
    bsdfs, emitters = _children(plugin, "bsdf"), _children(plugin, "emitter")
    if len(bsdfs) > 1 or len(emitters) > 1:
        raise _error(plugin, "a shape takes at most one bsdf and one emitter")
    reflectance, twosided = _material(bsdfs[0] if bsdfs else None)
    radiance = None
    if emitters:
        if emitters[0].type != "area":
            raise _error(emitters[0], "a shape's emitter must be area")
        radiance = _emitter(emitters[0])
    name = plugin.id or f"{plugin.type}-line{plugin.line}"
    return Mesh(name, positions, faces, normals, reflectance, twosided, radiance)


def _mesh_file(plugin: Plugin, props: _Props, to_world: np.ndarray, folders: list[str]):
    """Positions, faces and shading normals of an ``obj`` or ``ply`` shape, in world space.

    As Mitsuba: the file's normals go through the inverse transpose; without them (and
    without ``face_normals``) the smooth angle-weighted vertex normals of the transformed
    mesh; with ``face_normals`` flat faces.
    """
    name = props.get("filename", ("string",))
    if name is None:
        raise props.error(f"{plugin.type} needs a filename")
    face_normals = props.get("face_normals", ("boolean",), False)
    for folder in folders:
        path = os.path.join(folder, name)
        if os.path.isfile(path):
            break
    else:
        raise props.error(f"mesh file \"{name}\" not found (looked in {', '.join(folders)})")
    try:
        data = (read_obj if plugin.type == "obj" else read_ply)(path)
    except (OSError, MeshFormatError) as e:
        raise props.error(f"cannot read {name}: {e}") from None
    positions = _points(to_world, data.positions)
    faces = np.asarray(data.faces, dtype=np.int64)
    if face_normals:
        normals = None
    elif data.normals is not None:
        normals = _normals(to_world, data.normals)
    else:
        normals = smooth_vertex_normals(positions, faces)
    return positions, faces, normals


def _sensor(plugin: Plugin, width: int | None, height: int | None, spp: int | None,
            seed: int | None) -> tuple[Camera, int, int, int, int]:
    """The camera, film size, sample count and seed of a ``perspective`` sensor."""
    if plugin.type != "perspective":
        raise _refuse(plugin)
    _only_children(plugin, {"film", "sampler"})
    films, samplers = _children(plugin, "film"), _children(plugin, "sampler")
    file_width, file_height = _film(films[0]) if films else (768, 576)
    if not films:
        raise _error(plugin, "the default film has a gaussian filter: give an hdrfilm with "
                     "<rfilter type=\"box\"/>")
    file_spp, file_seed = 4, 0
    if samplers:
        sampler = samplers[0]
        if sampler.type not in SAMPLERS:
            raise _refuse(sampler)
        sprops = _Props(sampler)
        file_spp = sprops.get("sample_count", ("integer",), 4)
        file_seed = sprops.get("seed", ("integer",), 0)
        sprops.get("jitter", ("boolean",))
        sprops.get("strength", ("integer",))
        sprops.finish()
    width, height = width or file_width, height or file_height
    props = _Props(plugin)
    fov = props.get("fov", ("float", "integer"))
    if fov is None:
        raise props.error("the subset needs fov (not focal_length)")
    axis = props.get("fov_axis", ("string",), "x").strip().lower()
    near = props.get("near_clip", ("float", "integer"), 1e-2)
    far = props.get("far_clip", ("float", "integer"), 1e4)
    props.get("focus_distance", ("float", "integer"))      # a pinhole: no effect
    to_world = props.get("to_world", ("transform",), np.eye(4))
    props.finish()
    try:
        x_fov = x_fov_from(fov, axis, width / height)
        matrix, mirrored = blender_camera(to_world)
    except ValueError as e:
        raise props.error(str(e)) from None
    camera = Camera(matrix, x_fov, float(near), float(far), mirrored, float(fov))
    return camera, width, height, spp or file_spp, file_seed if seed is None else seed


def _film(plugin: Plugin) -> tuple[int, int]:
    if plugin.type != "hdrfilm":
        raise _refuse(plugin)
    _only_children(plugin, {"rfilter"})
    filters = _children(plugin, "rfilter")
    if not filters or filters[0].type != "box":
        raise _error(filters[0] if filters else plugin, "the film needs <rfilter type=\"box\"/> "
                     "(Mitsuba's default is gaussian; Cycles' box of width 1 is the same box)")
    _Props(filters[0]).finish()
    props = _Props(plugin)
    width = props.get("width", ("integer",), 768)
    height = props.get("height", ("integer",), 576)
    for name in FILM_FORMAT_PROPS:
        props.get(name, ("string",))
    props.finish()
    return width, height


def _integrator(plugin: Plugin | None) -> int:
    """``max_depth`` of the ``path`` integrator (Mitsuba's default integrator is path, -1)."""
    if plugin is None:
        return -1
    if plugin.type != "path":
        raise _refuse(plugin)
    _only_children(plugin, set())
    props = _Props(plugin)
    max_depth = props.get("max_depth", ("integer",), -1)
    props.get("rr_depth", ("integer",))                     # Russian roulette: unbiased
    if props.get("hide_emitters", ("boolean",), False):
        raise props.error("hide_emitters is outside the subset")
    props.finish()
    return max_depth


def translate(path: str, params: dict | None = None, *, width: int | None = None,
              height: int | None = None, spp: int | None = None, seed: int | None = None,
              max_depth: int | None = None) -> SceneDesc:
    """Read a Mitsuba 3 scene file of the subset into a :class:`SceneDesc`.

    Parameters
    ----------
    path : str
        The scene file.
    params : dict, optional
        ``$name`` values, as ``-D name=value`` gives them to Mitsuba.
    width, height, spp, seed, max_depth : int, optional
        Replace the file's film size, sample count, seed and path length (the field of
        view keeps its ``fov_axis`` at the new aspect, as in Mitsuba).

    Raises
    ------
    SceneError
        A syntax error (the project's parser) or, as :class:`SubsetError`, anything outside
        the subset; the message is one line naming the file, line and plugin.
    """
    root = parse_file(path, params)
    folders = list(root.search_paths) + [os.path.dirname(os.path.abspath(path)), os.getcwd()]
    sensors, integrators = _children(root, "sensor"), _children(root, "integrator")
    meshes, background = [], None
    for child in root.children:
        if child.kind == "shape":
            meshes.append(_shape(child, folders))
        elif child.kind == "emitter":
            if child.type not in ("area", "constant"):
                raise _refuse(child)
            if child.type == "area" or background is not None:
                raise _error(child, "an area emitter belongs inside a shape, and the subset has "
                             "at most one constant environment")
            background = _emitter(child)
        elif child.kind == "bsdf":
            _material(child)                # checked here; used where a shape refers to it
        elif child.kind not in ("sensor", "integrator"):
            raise _refuse(child)
    if len(sensors) != 1 or len(integrators) > 1:
        raise SubsetError("the subset needs exactly one sensor and at most one integrator",
                          root.file, root.line, "<scene>")
    camera, w, h, n, s = _sensor(sensors[0], width, height, spp, seed)
    depth = _integrator(integrators[0] if integrators else None)
    return SceneDesc(path, camera, w, h, n, s, depth if max_depth is None else max_depth,
                     meshes, background)
