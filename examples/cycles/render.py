"""Render the Cornell-box subset of a Mitsuba 3 scene file with Blender's Cycles (``bpy``).

Reads SCENE with ``translate.py`` (the project's XML parser; anything outside the subset is
refused with one line naming the file, line and plugin), builds the Blender scene, renders
it with Cycles on the CPU, headless, and writes one linear float EXR (rows top to bottom, R,
G, B, no alpha): the image Mitsuba's ``path`` integrator would converge to. Every Cycles
setting that would change the expected image is set to Mitsuba's convention (README.md,
"Conventions"); ``--factory`` leaves Cycles' defaults instead, to show what they cost::

    python examples/cycles/render.py SCENE.xml --spp 64 --seed 1 -o out.exr \\
        [--width W --height H --max-depth D -D name=value ... --threads T --factory]

Exit status 0, 1 when Blender fails or the output cannot be written, 2 for bad arguments or
a scene outside the subset (one line on stderr).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from translate import SceneDesc, cycles_bounces, cycles_seed, lens_for_fov, translate

from pathtracer.scene.errors import SceneError

#: Cycles' "Sobol-Burley" pattern: a per-pixel Owen-scrambled Sobol sequence seeded by a hash
#: of (pixel, seed), so pixels and seeds have independent noise (the harness's statistics assume
#: it). Blender lists it only with developer extras on; the default ("Automatic") is blue noise,
#: one sequence shared by all pixels.
SAMPLING_PATTERN = "SOBOL_BURLEY"

#: One convention undone at a time (``--deviate NAME``), to measure what each costs with the
#: harness (README.md, "Conventions"): each is what Cycles does by default or what a first
#: translation easily does.
DEVIATIONS = {
    "centre-sample": "Cycles' sample 0 at every pixel's centre (no sample subset)",
    "two-sided-lights": "emission from both sides of the light (Cycles' default)",
    "two-sided-diffuse": "diffuse surfaces reflect on both sides (Cycles' default)",
    "filter": "Cycles' default pixel filter, Blackman-Harris 1.5 pixels wide",
    "diffuse-bounces": "Cycles' default of 4 diffuse bounces",
    "max-bounces": "bounces = max_depth - 1 instead of max_depth - 2",
    "denoiser": "Cycles' default denoiser (OpenImageDenoise)",
    "clamp": "Cycles' default indirect clamp of 10",
    "light-threshold": "Cycles' default light threshold of 0.01",
    "adaptive": "Cycles' default adaptive sampling (noise threshold 0.01)",
    "fov-axis": "Mitsuba's fov given to Blender's camera angle with sensor_fit AUTO (the larger axis)",
    "blue-noise": "Cycles' default 'Automatic' (blue-noise) sampling pattern",
}
#: What ``--factory`` undoes: every default of Cycles (and its bounce counts, 12 and 4 diffuse).
FACTORY = frozenset(DEVIATIONS) - {"max-bounces", "fov-axis", "diffuse-bounces"}


def parse_args(argv=None) -> argparse.Namespace:
    """The command line (argparse exits with 2 and one usage line on stderr when it is wrong)."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", help="Mitsuba 3 XML scene file of the subset")
    parser.add_argument("-o", "--out", required=True, help="linear float EXR to write")
    parser.add_argument("--spp", type=int, required=True, help="samples per pixel")
    parser.add_argument("--seed", type=int, required=True, help="0 to 2^32 - 1 (its low 31 bits reach Cycles)")
    parser.add_argument("--width", type=int, help="film width (default: the file's)")
    parser.add_argument("--height", type=int, help="film height (default: the file's)")
    parser.add_argument("--max-depth", type=int, help="Mitsuba's max_depth; -1 unbounded (default: the file's)")
    parser.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                        help="scene parameter, as Mitsuba's -D")
    parser.add_argument("--threads", type=int, default=1, help="Cycles CPU threads (default 1)")
    parser.add_argument("--factory", action="store_true",
                        help="keep Cycles' default settings and two-sided materials and lights")
    parser.add_argument("--deviate", choices=sorted(DEVIATIONS), action="append", default=[],
                        help="undo one convention, to measure its cost (repeatable)")
    args = parser.parse_args(argv)
    if args.spp < 1 or args.threads < 1 or not 0 <= args.seed < 2 ** 32:
        parser.error("--spp and --threads must be >= 1 and --seed in [0, 2^32)")
    if (args.width is not None and args.width < 1) or (args.height is not None and args.height < 1):
        parser.error("--width and --height must be >= 1")
    if args.max_depth is not None and args.max_depth < -1:
        parser.error("--max-depth must be -1 or >= 0")
    params = {}
    for text in args.defines:
        name, sep, value = text.partition("=")
        if not sep or not name:
            parser.error(f"-D takes NAME=VALUE, got {text!r}")
        params[name] = value
    args.params = params
    return args


# ---- Blender ----------------------------------------------------------------------------

def build_material(bpy, name: str, mesh, max_depth: int, deviate: frozenset):
    """A node material: Mitsuba's one-sided diffuse (black behind), plus a front-only emission.

    Emission is an Emission shader of Strength 1 and Color = Mitsuba's radiance: Cycles'
    surface emission is radiance (W m^-2 sr^-1 per unit of Strength), so no power, area or pi
    factor enters, unlike a Blender area light, whose Power is in watts. ``max_depth`` 1 shows
    emission only (the BSDF becomes black), 0 nothing.
    """
    material = bpy.data.materials.new(name)
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    output = nodes.new("ShaderNodeOutputMaterial")
    reflectance = mesh.reflectance if max_depth != 1 else np.zeros(3)
    radiance = mesh.radiance if max_depth != 0 else None
    two_sided_diffuse = mesh.twosided or "two-sided-diffuse" in deviate
    diffuse = _diffuse(nodes, reflectance)
    emission = None
    if radiance is not None:
        emission = nodes.new("ShaderNodeEmission")
        emission.inputs["Color"].default_value = (*radiance, 1.0)
        emission.inputs["Strength"].default_value = 1.0
    # Cycles' surfaces are two-sided; the Backfacing output (the geometric normal's side)
    # picks what the back of a one-sided surface does: nothing (no closure ends the path).
    backfacing = nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"]
    surface = diffuse.outputs[0]
    if not two_sided_diffuse:
        surface = _mix(nodes, links, backfacing, surface, _diffuse(nodes, np.zeros(3)).outputs[0])
    if emission is not None:
        light = emission.outputs[0]
        if "two-sided-lights" not in deviate:
            light = _mix(nodes, links, backfacing, light, _diffuse(nodes, np.zeros(3)).outputs[0])
        add = nodes.new("ShaderNodeAddShader")
        links.new(surface, add.inputs[0])
        links.new(light, add.inputs[1])
        surface = add.outputs[0]
    links.new(surface, output.inputs["Surface"])
    # Light sampling picks points on the emitting side only.
    if radiance is None:
        material.cycles.emission_sampling = "NONE"
    elif "two-sided-lights" not in deviate:
        material.cycles.emission_sampling = "FRONT"
    return material


def _diffuse(nodes, reflectance):
    node = nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (*reflectance, 1.0)
    node.inputs["Roughness"].default_value = 0.0            # Lambert, not Oren-Nayar
    return node


def _mix(nodes, links, fac, first, second):
    node = nodes.new("ShaderNodeMixShader")
    links.new(fac, node.inputs["Fac"])
    links.new(first, node.inputs[1])
    links.new(second, node.inputs[2])
    return node.outputs[0]


def build_scene(bpy, desc: SceneDesc, deviate: frozenset):
    """The Blender scene of ``desc`` in a fresh, empty file (Mitsuba's world coordinates as
    they are: which axis is up does not matter to a renderer, only the camera's frame)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    for mesh in desc.meshes:
        data = bpy.data.meshes.new(mesh.name)
        data.from_pydata(mesh.positions.tolist(), [], mesh.faces.tolist())
        if mesh.normals is not None:
            data.shade_smooth()
            data.normals_split_custom_set_from_vertices(mesh.normals.tolist())
        else:
            data.shade_flat()
        data.materials.append(build_material(bpy, mesh.name, mesh, desc.max_depth, deviate))
        obj = bpy.data.objects.new(mesh.name, data)
        obj.cycles.shadow_terminator_geometry_offset = 0.0  # no shadow-ray offset for smooth normals
        scene.collection.objects.link(obj)
    world = bpy.data.worlds.new("world")
    background = world.node_tree.nodes["Background"]
    radiance = desc.background if desc.background is not None and desc.max_depth != 0 else np.zeros(3)
    background.inputs["Color"].default_value = (*radiance, 1.0)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world
    camera = bpy.data.cameras.new("camera")
    camera.type = "PERSP"
    camera.sensor_width = 36.0
    if "fov-axis" in deviate:
        camera.sensor_fit, camera.angle = "AUTO", np.deg2rad(desc.camera.file_fov)
    else:
        camera.sensor_fit = "HORIZONTAL"                    # Mitsuba's fov is converted to x
        camera.lens = lens_for_fov(desc.camera.x_fov, camera.sensor_width)
    camera.clip_start, camera.clip_end = desc.camera.near_clip, desc.camera.far_clip
    obj = bpy.data.objects.new("camera", camera)
    obj.matrix_world = desc.camera.matrix.T.tolist()        # mathutils takes rows
    scene.collection.objects.link(obj)
    scene.camera = obj
    return scene


def configure(bpy, scene, desc: SceneDesc, threads: int, deviate: frozenset) -> None:
    """Film, sampling and output settings: Mitsuba's conventions, less those in ``deviate``."""
    render = scene.render
    render.engine = "CYCLES"
    render.resolution_x, render.resolution_y = desc.width, desc.height
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.threads_mode, render.threads = "FIXED", threads
    render.film_transparent = False
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = desc.spp
    cycles.seed = cycles_seed(desc.seed)
    cycles.use_animated_seed = False
    # The EXR holds scene-linear radiance whatever the view transform (measured: AgX and
    # Standard give bit-identical files); Standard and no dithering all the same.
    view = scene.view_settings
    view.view_transform, view.look, view.exposure, view.gamma = "Standard", "None", 0.0, 1.0
    render.dither_intensity = 0.0
    if "centre-sample" not in deviate:
        # Cycles puts sample 0 of every pixel at its centre: render samples 1 to spp instead
        # (the "sample subset" of spp + 1 samples that starts at 1).
        cycles.samples = desc.spp + 1
        cycles.use_sample_subset = True
        cycles.sample_offset = 1
        cycles.sample_subset_length = desc.spp
    if "filter" not in deviate:
        cycles.pixel_filter_type, cycles.filter_width = "BOX", 1.0
    if "blue-noise" not in deviate:
        bpy.context.preferences.experimental.use_cycles_debug = True
        bpy.context.preferences.view.show_developer_ui = True
        cycles.sampling_pattern = SAMPLING_PATTERN
        cycles.scrambling_distance = 1.0
    if "adaptive" not in deviate:
        cycles.use_adaptive_sampling = False
    if "denoiser" not in deviate:
        cycles.use_denoising = False
    if "clamp" not in deviate:
        cycles.sample_clamp_direct = cycles.sample_clamp_indirect = 0.0
    if "light-threshold" not in deviate:
        cycles.light_sampling_threshold = 0.0
    cycles.use_guiding = False
    cycles.blur_glossy = 0.0                            # "filter glossy": no blur of caustics
    cycles.caustics_reflective = cycles.caustics_refractive = True
    cycles.film_exposure = 1.0
    if "factory" not in deviate:
        bounces = 0 if desc.max_depth in (0, 1) else cycles_bounces(desc.max_depth)
        if "max-bounces" in deviate:
            bounces += 1
        cycles.max_bounces = bounces
        cycles.diffuse_bounces = cycles.glossy_bounces = cycles.transmission_bounces = bounces
        cycles.volume_bounces = cycles.transparent_max_bounces = bounces
        cycles.min_light_bounces = cycles.min_transparent_bounces = 0
        if "diffuse-bounces" in deviate:
            cycles.diffuse_bounces = min(bounces, 4)
    settings = render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_mode = "RGB"
    settings.color_depth = "32"
    settings.exr_codec = "ZIP"
    render.use_file_extension = False
    render.use_stamp = False


def write_flipped(path: str) -> None:
    """Flip an RGB float EXR left to right in place (a mirroring sensor ``to_world``)."""
    import OpenEXR

    with OpenEXR.File(path, separate_channels=True) as exr:
        channels = {name: np.ascontiguousarray(ch.pixels[:, ::-1]) for name, ch in exr.channels().items()}
        header = dict(exr.header())
    OpenEXR.File(header, channels).write(path)


def render(desc: SceneDesc, out: str, threads: int = 1, deviate=()) -> None:
    """Build, render and write ``out`` (``bpy`` is imported here, the translation needs none).

    ``deviate``: names of :data:`DEVIATIONS` to undo, or ``"factory"`` for all of Cycles'
    defaults (also its bounce counts: 12 in all, 4 diffuse).
    """
    import bpy

    deviate = frozenset(deviate)
    if "factory" in deviate:
        deviate |= FACTORY
    scene = build_scene(bpy, desc, deviate)
    configure(bpy, scene, desc, threads, deviate)
    with tempfile.TemporaryDirectory() as tmp:
        target = os.path.join(tmp, "render.exr")
        scene.render.filepath = target
        bpy.ops.render.render(write_still=True)
        if not os.path.isfile(target):
            raise RuntimeError("Blender wrote no image")
        if desc.camera.mirrored:
            write_flipped(target)
        os.replace(target, out) if _same_device(tmp, out) else Path(out).write_bytes(Path(target).read_bytes())


def _same_device(folder: str, out: str) -> bool:
    try:
        return os.stat(folder).st_dev == os.stat(os.path.dirname(os.path.abspath(out))).st_dev
    except OSError:
        return False


def main(argv=None) -> int:
    """Translate, render, write; one line on stderr and exit 2 for a scene outside the subset."""
    args = parse_args(argv)
    try:
        desc = translate(args.scene, args.params, width=args.width, height=args.height,
                         spp=args.spp, seed=args.seed, max_depth=args.max_depth)
    except (SceneError, OSError) as e:
        print(f"render.py: {e}", file=sys.stderr)
        return 2
    if not os.path.isdir(os.path.dirname(os.path.abspath(args.out))):
        print(f"render.py: cannot write {args.out}: no such folder", file=sys.stderr)
        return 1
    try:
        render(desc, args.out, args.threads, set(args.deviate) | ({"factory"} if args.factory else set()))
    except (RuntimeError, OSError) as e:
        print(f"render.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
