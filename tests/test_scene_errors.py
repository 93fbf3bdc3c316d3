"""Every SceneError names the file, the line and the offending element."""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pytest

from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene

FILM = ('<film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/>'
        '<rfilter type="box"/></film>')
SENSOR = f'<sensor type="perspective"><float name="fov" value="40"/>{FILM}</sensor>'
MARK = "<!--L-->"  # marks the line the error must point at


def load_text(tmp_path, body: str, sensor: str = SENSOR, name: str = "broken.xml", **params):
    text = f'<scene version="3.0.0">\n{sensor}\n{body}\n</scene>\n'
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(str(path), **params)
    lines = text.splitlines()
    marked = [i + 1 for i, line in enumerate(lines) if MARK in line]
    return str(info.value), (marked[0] if marked else None)


CASES = {
    "unknown bsdf": (
        f'<shape type="cube"><bsdf type="hair"/>{MARK}</shape>',
        '<bsdf type="hair">', "unsupported BSDF (supported: diffuse"),
    "polarised-only bsdf": (
        f'<shape type="cube"><bsdf type="polarizer"/>{MARK}</shape>',
        '<bsdf type="polarizer">', "_polarized variants"),
    "unknown shape": (
        f'<shape type="heightfield">{MARK}</shape>', '<shape type="heightfield">', "unsupported shape"),
    "unknown emitter": (
        f'<emitter type="sunsky"/>{MARK}', '<emitter type="sunsky">', "unsupported emitter"),
    "unknown integrator": (
        f'<integrator type="photonmapper"/>{MARK}', '<integrator type="photonmapper">',
        "unsupported integrator"),
    "integrator parameter": (
        f'<integrator type="path">\n<float name="max_depth" value="3"/>{MARK}</integrator>',
        '<integrator type="path">', 'must be an <integer>'),
    "unknown integrator parameter": (
        f'<integrator type="path">\n<integer name="samples_per_pass" value="3"/>{MARK}</integrator>',
        '<integrator type="path">', 'unsupported property "samples_per_pass"'),
    "unknown shape property": (
        f'<shape type="cube">\n<float name="radius" value="2"/>{MARK}</shape>',
        '<shape type="cube">', 'unsupported property "radius"'),
    "texture without filename": (
        f'<bsdf type="diffuse"><texture type="bitmap" name="reflectance"/>{MARK}</bsdf>',
        '<texture type="bitmap">', 'missing <string name="filename">'),
    "spectrum plugin": (
        f'<bsdf type="diffuse">\n<spectrum name="reflectance" type="blackbody"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', "spectrum plugins"),
    "spectrum wavelengths not increasing": (
        f'<bsdf type="diffuse">\n<spectrum name="reflectance" value="500:0.1, 400:0.2"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', "must increase"),
    "polarizer": (
        f'<shape type="cube"><bsdf type="polarizer"/>{MARK}</shape>',
        '<bsdf type="polarizer">', "polarized variants"),
    "projective integrator": (
        f'<integrator type="prb_projective"/>{MARK}', '<integrator type="prb_projective">',
        "differentiable"),
    "shape not implemented": (
        f'<shape type="ellipsoids">{MARK}</shape>', '<shape type="ellipsoids">',
        "not implemented in this tracer"),
    "curve without its file": (
        f'<shape type="bsplinecurve">{MARK}</shape>', '<shape type="bsplinecurve">',
        "missing <string name=\"filename\">"),
    "direct samples both ways": (
        f'<integrator type="direct">\n<integer name="shading_samples" value="2"/>{MARK}'
        '<integer name="bsdf_samples" value="2"/></integrator>', '<integrator type="direct">',
        "either shading_samples"),
    "area emitter on two shapes": (
        '<emitter type="area" id="glow"/>\n<shape type="cube"><ref id="glow"/></shape>\n'
        f'<shape type="sphere"><ref id="glow"/>{MARK}</shape>', '<shape type="sphere">',
        "already attached"),
    "missing search path": (
        f'<path value="no/such/folder"/>{MARK}', "<path>", "not found"),
    "missing image": (
        f'<bsdf type="diffuse"><texture type="bitmap" name="reflectance">\n'
        f'<string name="filename" value="nothere.png"/>{MARK}</texture></bsdf>',
        '<texture type="bitmap">', 'file not found: "nothere.png"'),
    "unknown wrap mode": (
        f'<bsdf type="diffuse"><texture type="bitmap" name="reflectance">\n'
        f'<string name="wrap_mode" value="wrap"/>{MARK}</texture></bsdf>',
        '<texture type="bitmap">', 'unknown wrap_mode "wrap" (supported: repeat, mirror, clamp)'),
    "unknown texture": (
        f'<bsdf type="diffuse"><texture type="volume" name="reflectance"/>{MARK}</bsdf>',
        '<texture type="volume">',
        "unsupported texture (supported: bitmap, checkerboard, rawconstant, mesh_attribute)"),
    "texture for a scalar parameter": (
        f'<bsdf type="roughplastic">\n<texture type="checkerboard" name="alpha"/>{MARK}</bsdf>',
        '<texture type="checkerboard">', 'roughplastic takes a number for "alpha"'),
    "texture for int_ior": (
        f'<bsdf type="plastic">\n<texture type="checkerboard" name="int_ior"/>{MARK}</bsdf>',
        '<texture type="checkerboard">', 'a texture for "int_ior" is not supported'),
    "checkerboard colour above 1": (
        f'<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">\n'
        f'<rgb name="color0" value="1.5, 0.2, 0.2"/>{MARK}</texture></bsdf>',
        '<texture type="checkerboard">', '"color0" must lie in [0, 1]'),
    "texture without a name": (
        f'<bsdf type="diffuse">\n<texture type="checkerboard"/>{MARK}</bsdf>',
        '<texture type="checkerboard">', "needs a name"),
    "malformed rgb": (
        f'<bsdf type="diffuse">\n<rgb name="reflectance" value="1,2,x"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', '"x"'),
    "malformed translate": (
        f'<shape type="cube"><transform name="to_world">\n<translate x="1..2"/>{MARK}</transform></shape>',
        '<shape type="cube">', "1..2"),
    "singular transform": (
        f'<shape type="cube"><transform name="to_world">{MARK}<scale value="0"/></transform></shape>',
        '<shape type="cube">', "singular"),
    "degenerate lookat": (
        f'<shape type="cube"><transform name="to_world">\n'
        f'<lookat origin="0,0,0" target="0,0,1" up="0,0,1"/>{MARK}</transform></shape>',
        '<shape type="cube">', "parallel"),
    "lookat target equals origin": (
        f'<shape type="cube"><transform name="to_world">\n'
        f'<lookat origin="1,1,1" target="1,1,1"/>{MARK}</transform></shape>',
        '<shape type="cube">', "target equals origin"),
    "non-unit rotation axis on a disk": (
        f'<shape type="disk">\n<transform name="to_world">{MARK}<rotate value="1,1,0" angle="45"/>'
        '</transform></shape>', '<shape type="disk">', "non-unit axis"),
    "unknown parameter": (
        f'<shape type="cube"><float name="radius" value="$size"/>{MARK}</shape>',
        '<shape type="cube">', "undefined parameter $size"),
    "bad ref": (
        f'<bsdf type="diffuse" id="white"/>\n<shape type="cube"><ref id="whte"/>{MARK}</shape>',
        '<shape type="cube">', 'no element with this id (ids defined: white)'),
    "unknown property": (
        f'<bsdf type="diffuse">\n<float name="roughness" value="0.1"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', 'unsupported property "roughness"'),
    "conductor material": (
        f'<bsdf type="conductor">\n<string name="material" value="Unobtainium"/>{MARK}</bsdf>',
        '<bsdf type="conductor">', 'unknown conductor material "Unobtainium" (known: none, Ag'),
    "conductor eta and material": (
        f'<bsdf type="roughconductor">\n<string name="material" value="Au"/>{MARK}\n'
        '<rgb name="eta" value="0.2"/></bsdf>',
        '<bsdf type="roughconductor">', 'give either eta/k or material="Au", not both'),
    "conductor k and material": (
        f'<bsdf type="conductor">\n<string name="material" value="Cu"/>\n<rgb name="k" value="2"/>{MARK}</bsdf>',
        '<bsdf type="conductor">', '"k" without "eta"'),
    "anisotropic roughplastic": (
        f'<bsdf type="roughplastic">\n<float name="alpha_u" value="0.1"/>{MARK}\n'
        '<float name="alpha_v" value="0.2"/></bsdf>',
        '<bsdf type="roughplastic">', "only isotropic roughness"),
    "roughdielectric equal iors": (
        f'<bsdf type="roughdielectric">\n<float name="int_ior" value="1.2"/>{MARK}\n'
        '<float name="ext_ior" value="1.2"/></bsdf>',
        '<bsdf type="roughdielectric">', "int_ior != ext_ior"),
    "negative roughness": (
        f'<bsdf type="roughdielectric">\n<float name="alpha" value="-0.1"/>{MARK}</bsdf>',
        '<bsdf type="roughdielectric">', '"alpha" must be >= 0'),
    "plastic nonlinear type": (
        f'<bsdf type="plastic">\n<float name="nonlinear" value="1"/>{MARK}</bsdf>',
        '<bsdf type="plastic">', 'must be a <boolean>'),
    "sample_visible": (
        f'<bsdf type="roughdielectric">\n<boolean name="sample_visible" value="false"/>{MARK}</bsdf>',
        '<bsdf type="roughdielectric">', "biased estimator"),
    "unknown ior name": (
        f'<bsdf type="dielectric">\n<string name="int_ior" value="unobtainium"/>{MARK}</bsdf>',
        '<bsdf type="dielectric">', "unknown IOR name"),
    "two environment emitters": (
        f'<emitter type="constant"/>\n<emitter type="constant"/>{MARK}',
        '<emitter type="constant">', "at most one environment emitter"),
    "ellipsoid sphere": (
        f'<shape type="sphere">{MARK}<transform name="to_world"><scale x="2"/></transform></shape>',
        '<shape type="sphere">', "uniformly"),
    "missing mesh": (
        f'<shape type="obj">\n<string name="filename" value="meshes/nothere.obj"/>{MARK}</shape>',
        '<shape type="obj">', os.path.join("meshes", "nothere.obj")),
    "duplicate property": (
        f'<bsdf type="diffuse"><rgb name="reflectance" value="0.1"/>\n'
        f'<rgb name="reflectance" value="0.2"/>{MARK}</bsdf>', '<bsdf type="diffuse">', "given twice"),
    "nan radiance": (
        f'<shape type="sphere"><emitter type="area">\n<rgb name="radiance" value="nan"/>{MARK}</emitter></shape>',
        '<emitter type="area">', "not a finite number"),
    "inf radiance": (
        f'<emitter type="constant">\n<rgb name="radiance" value="1, inf, 1"/>{MARK}</emitter>',
        '<emitter type="constant">', "not a finite number"),
    "inf reflectance": (
        f'<bsdf type="diffuse">\n<float name="reflectance" value="-inf"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', "not a finite number"),
    "beyond float32": (
        f'<shape type="sphere">\n<float name="radius" value="1e39"/>{MARK}</shape>',
        '<shape type="sphere">', "not a finite number"),
    "nan translate": (
        f'<shape type="cube"><transform name="to_world">\n<translate x="nan"/>{MARK}</transform></shape>',
        '<shape type="cube">', "not a finite number"),
    "rgb reflectance above 1": (
        f'<bsdf type="diffuse">\n<rgb name="reflectance" value="0.5, 1.2, 0.5"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', '"reflectance" must lie in [0, 1]'),
    "float reflectance above 1": (
        f'<bsdf type="diffuse">\n<float name="reflectance" value="1.0001"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', '"reflectance" must lie in [0, 1]'),
    "negative reflectance": (
        f'<bsdf type="diffuse">\n<rgb name="reflectance" value="-0.1"/>{MARK}</bsdf>',
        '<bsdf type="diffuse">', '"reflectance" must lie in [0, 1]'),
    "conductor reflectance above 1": (
        f'<bsdf type="conductor">\n<rgb name="specular_reflectance" value="1.5"/>{MARK}</bsdf>',
        '<bsdf type="conductor">', '"specular_reflectance" must lie in [0, 1]'),
    "transmittance above 1": (
        f'<bsdf type="dielectric">\n<rgb name="specular_transmittance" value="2"/>{MARK}</bsdf>',
        '<bsdf type="dielectric">', '"specular_transmittance" must lie in [0, 1]'),
    "max_depth below -1": (
        f'<integrator type="path">\n<integer name="max_depth" value="-2"/>{MARK}</integrator>',
        '<integrator type="path">', "max_depth must be -1 (unlimited) or >= 0"),
    "max_depth below -1 in a project integrator": (
        f'<integrator type="path_nee">\n<integer name="max_depth" value="-7"/>{MARK}</integrator>',
        '<integrator type="path_nee">', "max_depth must be -1 (unlimited) or >= 0"),
    "twosided with three bsdfs": (
        f'<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="diffuse"/>{MARK}<bsdf type="diffuse"/></bsdf>',
        '<bsdf type="diffuse">', "at most 2"),
    "blendbsdf without weight": (
        f'<bsdf type="blendbsdf">{MARK}<bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>',
        '<bsdf type="blendbsdf">', 'missing "weight"'),
    "blendbsdf with one bsdf": (
        f'<bsdf type="blendbsdf">{MARK}<float name="weight" value="0.5"/><bsdf type="diffuse"/></bsdf>',
        '<bsdf type="blendbsdf">', "needs exactly 2 nested <bsdf>"),
    # participating media (tests/test_media.py tests what they render)
    "grid volume without a file": (
        f'<medium type="heterogeneous" id="m">\n<volume type="gridvolume" name="sigma_t"/>{MARK}'
        '</medium>', '<volume type="gridvolume">', 'missing <string name="filename">'),
    "spectral-only phase": (
        f'<medium type="homogeneous">\n<phase type="rayleigh"/>{MARK}</medium>',
        '<phase type="rayleigh">', "spectral variants"),
    "grid volume": (
        f'<medium type="homogeneous">\n<volume type="gridvolume" name="sigma_t"/>{MARK}</medium>',
        '<volume type="gridvolume">', "a homogeneous medium reads one <volume>, its albedo"),
    "mitsuba 0.6 coefficients": (
        f'<medium type="homogeneous">\n<rgb name="sigma_a" value="0.5"/>{MARK}\n'
        f'<rgb name="sigma_s" value="1.5, 1, 0.5"/></medium>',
        '<medium type="homogeneous">', "sigma_t = sigma_a + sigma_s = 2, 1.5, 1, albedo = "
        "sigma_s / sigma_t = 0.75, 0.666667, 0.5"),
    "rgb sigma_t above 1": (
        f'<medium type="homogeneous">\n<rgb name="sigma_t" value="2, 1, 1"/>{MARK}</medium>',
        '<medium type="homogeneous">', "an <rgb> sigma_t must lie in [0, 1]"),
    "hg g out of range": (
        f'<medium type="homogeneous"><phase type="hg">\n<float name="g" value="1"/>{MARK}</phase></medium>',
        '<phase type="hg">', "g must lie in (-1, 1)"),
    "shape medium without side": (
        f'<shape type="cube">\n<medium type="homogeneous"/>{MARK}</shape>',
        '<medium type="homogeneous">', 'needs name="interior" or name="exterior"'),
    "two interior media": (
        f'<medium type="homogeneous" id="a"/><shape type="cube"><ref id="a" name="interior"/>'
        f'\n<medium type="homogeneous" name="interior"/>{MARK}</shape>',
        '<medium type="homogeneous">', "has two interior media"),
    "null bsdf parameter": (
        f'<bsdf type="null">\n<float name="alpha" value="0.1"/>{MARK}</bsdf>',
        '<bsdf type="null">', 'unsupported property "alpha"'),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_error_names_file_line_and_plugin(tmp_path, case):
    body, plugin, reason = CASES[case]
    message, line = load_text(tmp_path, body)
    assert f"broken.xml:{line}:" in message, message
    assert plugin in message, message
    assert reason in message, message


SENSOR_CASES = {
    "lanczos rfilter": (
        SENSOR.replace('<rfilter type="box"/>', f'\n<rfilter type="lanczos"/>{MARK}'),
        '<rfilter type="lanczos">', 'unsupported reconstruction filter "lanczos"'),
    "tent radius": (
        SENSOR.replace('<rfilter type="box"/>',
                       f'<rfilter type="tent">\n<float name="radius" value="-1"/>{MARK}</rfilter>'),
        '<rfilter type="tent">', "radius must lie in (0, 64]"),
    "gaussian parameter": (
        SENSOR.replace('<rfilter type="box"/>',
                       f'<rfilter type="gaussian">\n<float name="radius" value="2"/>{MARK}</rfilter>'),
        '<rfilter type="gaussian">', 'unsupported property "radius"'),
    "crop": (
        SENSOR.replace('<rfilter type="box"/>', f'<rfilter type="box"/>\n<integer name="crop_width" value="8"/>{MARK}'),
        '<film type="hdrfilm">', 'crop_width is not supported'),
    "sampler": (
        SENSOR.replace("</sensor>", f'\n<sampler type="halton"/>{MARK}</sensor>'),
        '<sampler type="halton">', "unsupported sampler (supported: independent, stratified"),
    "radiancemeter": (
        SENSOR.replace('"perspective">', f'"radiancemeter">{MARK}'), '<sensor type="radiancemeter">',
        "unsupported sensor"),
    "thinlens without aperture": (
        SENSOR.replace('"perspective">', f'"thinlens">{MARK}'), '<sensor type="thinlens">',
        "needs aperture_radius"),
    "camera scale": (
        SENSOR.replace("</sensor>", f'\n<transform name="to_world"><scale value="2"/></transform>{MARK}</sensor>')
        .replace("<sensor", "<sensor"),
        '<sensor type="perspective">', "scale factors"),
    "negative seed": (
        SENSOR.replace("</sensor>", f'<sampler type="independent">\n<integer name="seed" value="-1"/>{MARK}'
                       '</sampler></sensor>'),
        '<sampler type="independent">', "seed must lie in [0, 4294967295]"),
    "seed beyond 32 bits": (
        SENSOR.replace("</sensor>", f'<sampler type="independent">\n<integer name="seed" value="4294967296"/>{MARK}'
                       '</sampler></sensor>'),
        '<sampler type="independent">', "seed must lie in [0, 4294967295]"),
    "fov_axis": (
        SENSOR.replace("</sensor>", f'\n<string name="fov_axis" value="diag"/>{MARK}</sensor>'),
        '<sensor type="perspective">', "fov_axis"),
}


@pytest.mark.parametrize("case", sorted(SENSOR_CASES))
def test_sensor_errors(tmp_path, case):
    sensor, plugin, reason = SENSOR_CASES[case]
    message, line = load_text(tmp_path, "", sensor=sensor)
    if case == "camera scale":  # reported at the sensor element itself
        line = 2
    assert f"broken.xml:{line}:" in message, message
    assert plugin in message, message
    assert reason in message, message


def test_xml_syntax_error_reports_parser_line(tmp_path):
    message, _ = load_text(tmp_path, '<shape type="cube">\n\n<bsdf type="diffuse">\n</shape>')
    # The mismatched </shape> is on line 6 (scene, sensor, shape, blank, bsdf, </shape>).
    assert "broken.xml:6:" in message and "XML syntax error" in message


def test_unknown_param_in_sensor_names_it(tmp_path):
    sensor = SENSOR.replace('value="40"', 'value="$fov"')
    message, _ = load_text(tmp_path, "", sensor=sensor)
    assert "broken.xml:2:" in message and "$fov" in message
    # ... and a value passed to load_scene fixes it.
    path = tmp_path / "broken.xml"
    assert load_scene(str(path), fov=30).camera.x_fov == 30


def test_missing_file_and_builtin():
    with pytest.raises(SceneError, match="not found"):
        load_scene("/nonexistent/scene.xml")
    with pytest.raises(SceneError, match="no built-in scene \"no-such-scene\""):
        load_scene("no-such-scene")


def test_scene_error_is_value_error():
    assert issubclass(SceneError, ValueError)
    e = SceneError("bad", "a.xml", 3, '<bsdf type="x">')
    assert str(e) == 'a.xml:3: <bsdf type="x">: bad' and e.line == 3


@pytest.mark.parametrize("attribute,reason", [
    ("", "missing attribute version"),
    (' version="abc"', 'invalid version "abc"'),
    (' version="3.0"', 'invalid version "3.0"'),
    (' version=""', 'invalid version ""'),
    (' version="3.0.0.1"', 'invalid version "3.0.0.1"'),
])
def test_scene_version_is_required_and_has_three_numbers(tmp_path, attribute, reason):
    """As Mitsuba 3.9.1: "Missing version attribute" / "Invalid version number"."""
    path = tmp_path / "v.xml"
    path.write_text(f'<?xml version="1.0"?>\n<scene{attribute}>\n{SENSOR}\n</scene>\n')
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    assert str(info.value).startswith("v.xml:2: <scene>: ") and reason in str(info.value)


def test_values_at_the_edges_of_what_mitsuba_accepts_still_load(tmp_path):
    sampler = '<sampler type="independent"><integer name="seed" value="4294967295"/></sampler>'
    body = ('<integrator type="path"><integer name="max_depth" value="-1"/></integrator>\n'
            '<shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="0, 1, 0.5"/></bsdf>'
            '<emitter type="area"><rgb name="radiance" value="1e30"/></emitter></shape>')
    path = tmp_path / "edges.xml"
    path.write_text(f'<scene version="2.1.0">\n{SENSOR.replace("</sensor>", sampler + "</sensor>")}'
                    f'\n{body}\n</scene>\n')
    scene = load_scene(str(path))
    assert scene.seed == 2 ** 32 - 1 and scene.integrator.params["max_depth"] == -1
    assert scene.emitters[0].radiance[0] == 1e30


MESHES = {
    "nan.obj": "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n",
    "inf-normal.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 0 inf\nf 1//1 2//1 3//2\n",
    "nan.ply": ("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                "end_header\n0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n"),
}


@pytest.mark.parametrize("mesh,where", [("nan.obj", "nan.obj:3: vertex"),
                                        ("inf-normal.obj", "inf-normal.obj:5: normal"),
                                        ("nan.ply", "nan.ply: 1 vertex value(s) are not finite")])
def test_non_finite_mesh_coordinates_are_refused(tmp_path, mesh, where):
    (tmp_path / mesh).write_text(MESHES[mesh])
    kind = mesh.rsplit(".", 1)[1]
    message, line = load_text(
        tmp_path, f'<shape type="{kind}">\n<string name="filename" value="{mesh}"/>{MARK}</shape>')
    assert f"broken.xml:{line}:" in message and where in message and "not finite" in message


def test_unreadable_scene_is_a_scene_error(tmp_path, monkeypatch):
    import builtins
    path = tmp_path / "locked.xml"
    path.write_text("<scene/>")
    real_open = builtins.open

    def deny(file, *args, **kwargs):     # chmod does not stop root: refuse the open itself
        if str(file) == str(path):
            raise PermissionError(13, "Permission denied", str(file))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", deny)
    with pytest.raises(SceneError, match="locked.xml: cannot read the scene file: Permission denied"):
        load_scene(str(path))


def test_unreadable_mesh_is_a_scene_error(tmp_path, monkeypatch):
    import shutil

    from pathtracer.io import meshes
    shutil.copy(Path(__file__).parent / "data" / "pyramid.obj", tmp_path / "pyramid.obj")
    (tmp_path / "s.xml").write_text(
        f'<scene version="3.0.0">{SENSOR}\n<shape type="obj">'
        '<string name="filename" value="pyramid.obj"/></shape></scene>')

    def deny(path, *args, **kwargs):     # chmod does not stop root: refuse the read itself
        raise PermissionError(13, "Permission denied", str(path))

    monkeypatch.setattr(meshes, "read_obj", deny)
    with pytest.raises(SceneError, match='s.xml:2: .*cannot read mesh file "pyramid.obj": '
                                         "Permission denied"):
        load_scene(str(tmp_path / "s.xml"))


@pytest.mark.mitsuba
def test_mitsuba_refuses_and_accepts_the_same_values(tmp_path, mi):
    """The refusals above follow Mitsuba 3.9.1: it refuses each of these files too, and
    loads the edge values."""
    integrator = '<integrator type="path"/>'
    refused = {
        "no version": f"<scene>{integrator}{SENSOR}</scene>",
        "bad version": f'<scene version="3.0">{integrator}{SENSOR}</scene>',
        "reflectance": f'<scene version="3.0.0">{integrator}{SENSOR}<bsdf type="diffuse">'
                       '<rgb name="reflectance" value="1.0001"/></bsdf></scene>',
        "checkerboard colour": f'<scene version="3.0.0">{integrator}{SENSOR}<bsdf type="diffuse">'
                               '<texture type="checkerboard" name="reflectance"><rgb name="color0" '
                               'value="1.5, 0.2, 0.2"/></texture></bsdf></scene>',
        "seed": f'<scene version="3.0.0">{integrator}' + SENSOR.replace(
            "</sensor>", '<sampler type="independent"><integer name="seed" value="-1"/></sampler></sensor>')
        + "</scene>",
        "max_depth": f'<scene version="3.0.0"><integrator type="path"><integer name="max_depth" '
                     f'value="-2"/></integrator>{SENSOR}</scene>',
    }
    for name, text in refused.items():
        with pytest.raises(Exception):
            mi.load_string(text)
        path = tmp_path / f"{name.replace(' ', '_')}.xml"
        path.write_text(text)
        with pytest.raises(SceneError):
            load_scene(str(path))
    edges = ('<scene version="2.1.0"><integrator type="path"><integer name="max_depth" value="-1"/>'
             '</integrator>' + SENSOR.replace("</sensor>", '<sampler type="independent"><integer '
             'name="seed" value="4294967295"/></sampler></sensor>')
             + '<bsdf type="diffuse"><rgb name="reflectance" value="0, 1, 0.5"/></bsdf>'
             # a texture's <float> value is not range-checked (principledthin's diff_trans
             # reaches 2: mitsuba-data's test_texturedprincipledthin_path has 1.4)
             '<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
             '<float name="color1" value="1.4"/></texture></bsdf></scene>')
    mi.load_string(edges)
    path = tmp_path / "edges.xml"
    path.write_text(edges)
    load_scene(str(path))


def test_moment_integrator_renders_its_nested_integrator(tmp_path):
    """Mitsuba's ``moment`` wraps an integrator to add second moments: the nested one renders."""
    path = tmp_path / "m.xml"
    nested = '<integrator type="path"><integer name="max_depth" value="3"/></integrator>'
    path.write_text(f'<scene version="3.0.0"><integrator type="moment">{nested}</integrator>'
                    f'{SENSOR}</scene>')
    spec = load_scene(str(path)).integrator
    assert spec.name == "path" and spec.params == {"max_depth": 3}
    path.write_text(f'<scene version="3.0.0">\n<integrator type="moment"/>{SENSOR}</scene>')
    with pytest.raises(SceneError, match="m.xml:2: .*exactly one nested <integrator>"):
        load_scene(str(path))


def test_aov_integrator_renders_its_first_nested_integrator(tmp_path):
    """Mitsuba's ``aov`` film carries its first nested integrator's image in R, G, B (AOVs in
    extra channels): that integrator renders; the ``aovs`` string is checked as Mitsuba does."""
    path = tmp_path / "a.xml"
    nested = ('<integrator type="path" name="image"><integer name="max_depth" value="4"/>'
              '</integrator><integrator type="direct" name="second"/>')
    aovs = '<string name="aovs" value="nn:sh_normal, position:position,depth.y:depth"/>'
    path.write_text(f'<scene version="3.0.0"><integrator type="aov">{aovs}{nested}</integrator>'
                    f'{SENSOR}</scene>')
    spec = load_scene(str(path)).integrator
    assert spec.name == "path" and spec.params == {"max_depth": 4}
    refused = {
        "renders no radiance": f'<integrator type="aov">{aovs}</integrator>',
        "needs its \"aovs\"": '<integrator type="aov"><integrator type="path"/></integrator>',
        '"dd:colour" is not <name>:<type>': '<integrator type="aov"><string name="aovs" '
                                             'value="dd:colour"/><integrator type="path"/>'
                                             '</integrator>',
        'unsupported property "max_depth"': f'<integrator type="aov">{aovs}<integer '
                                            'name="max_depth" value="3"/><integrator '
                                            'type="path"/></integrator>',
    }
    for reason, integrator in refused.items():
        path.write_text(f'<scene version="3.0.0">\n{integrator}{SENSOR}</scene>')
        with pytest.raises(SceneError, match=f"a.xml:2: .*{re.escape(reason)}"):
            load_scene(str(path))


@pytest.mark.mitsuba
def test_mitsuba_aov_image_is_its_first_nested_integrators(tmp_path, mi):
    """What the tracer renders for an aov file is what Mitsuba's aov film carries in R, G, B:
    its first nested integrator's image (the same render, seed for seed), the AOVs after."""
    body = ('<shape type="sphere"><bsdf type="diffuse"/></shape><emitter type="constant"/>'
            + SENSOR.replace("</sensor>", '<transform name="to_world"><lookat origin="0, 0, 4" '
                             'target="0, 0, 0" up="0, 1, 0"/></transform></sensor>'))
    aov = ('<integrator type="aov"><string name="aovs" value="dd:depth, nn:sh_normal"/>'
           '<integrator type="path" name="image"><integer name="max_depth" value="3"/>'
           '</integrator></integrator>')
    path = '<integrator type="path"><integer name="max_depth" value="3"/></integrator>'
    images, channels = {}, {}
    for name, integrator in (("aov", aov), ("path", path)):
        file = tmp_path / f"{name}.xml"
        file.write_text(f'<scene version="3.0.0">{integrator}{body}</scene>')
        scene = mi.load_file(str(file))
        mi.render(scene, spp=4, seed=3)
        film = scene.sensors()[0].film().bitmap()
        images[name] = np.asarray(film)
        channels[name] = [f.name for f in film.struct_()]
    assert channels["aov"] == ["R", "G", "B", "image.R", "image.G", "image.B", "image.A",
                               "dd.T", "nn.X", "nn.Y", "nn.Z"]
    np.testing.assert_array_equal(images["aov"][..., :3], images["path"][..., :3])
    assert load_scene(str(tmp_path / "aov.xml")).integrator == \
        load_scene(str(tmp_path / "path.xml")).integrator


def test_a_root_other_than_scene_names_its_element(tmp_path):
    path = tmp_path / "fragment.xml"
    path.write_text('<?xml version="1.0"?>\n<shape type="sphere"/>\n')
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    assert str(info.value) == ('fragment.xml:2: <shape>: the root element must be <scene>, '
                               'not <shape>')
