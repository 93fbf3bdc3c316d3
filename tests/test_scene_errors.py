"""Every SceneError names the file, the line and the offending element."""
from __future__ import annotations

import os

import pytest

from pathtracer.scene import SceneError, load_scene

FILM = '<film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/><rfilter type="box"/></film>'
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
        f'<shape type="cube"><bsdf type="plastic"/>{MARK}</shape>',
        '<bsdf type="plastic">', "unsupported BSDF (supported: diffuse"),
    "unknown shape": (
        f'<shape type="serialized">{MARK}</shape>', '<shape type="serialized">', "unsupported shape"),
    "unknown emitter": (
        f'<emitter type="envmap"/>{MARK}', '<emitter type="envmap">', "unsupported emitter"),
    "unknown integrator": (
        f'<integrator type="volpath"/>{MARK}', '<integrator type="volpath">', "unsupported integrator"),
    "integrator parameter": (
        f'<integrator type="path">\n<float name="max_depth" value="3"/>{MARK}</integrator>',
        '<integrator type="path">', 'must be an <integer>'),
    "unknown integrator parameter": (
        f'<integrator type="path">\n<integer name="samples_per_pass" value="3"/>{MARK}</integrator>',
        '<integrator type="path">', 'unsupported property "samples_per_pass"'),
    "unknown shape property": (
        f'<shape type="cube">\n<float name="radius" value="2"/>{MARK}</shape>',
        '<shape type="cube">', 'unsupported property "radius"'),
    "texture": (
        f'<bsdf type="diffuse"><texture type="bitmap" name="reflectance"/>{MARK}</bsdf>',
        '<texture type="bitmap">', "use an <rgb>"),
    "spectrum": (
        f'<bsdf type="diffuse"><spectrum name="reflectance" value="0.5"/>{MARK}</bsdf>',
        "<spectrum>", "use <rgb>"),
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
    "non-unit rotation axis": (
        f'<shape type="cube"><transform name="to_world">\n<rotate value="1,1,0" angle="45"/>{MARK}'
        '</transform></shape>', '<shape type="cube">', "unit length"),
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
        f'<bsdf type="conductor">\n<string name="material" value="Au"/>{MARK}</bsdf>',
        '<bsdf type="conductor">', 'only material "none"'),
    "conductor eta": (
        f'<bsdf type="roughconductor">\n<rgb name="eta" value="0.2"/>{MARK}</bsdf>',
        '<bsdf type="roughconductor">', 'only material "none"'),
    "sample_visible": (
        f'<bsdf type="roughconductor">\n<boolean name="sample_visible" value="false"/>{MARK}</bsdf>',
        '<bsdf type="roughconductor">', "visible-normal"),
    "unknown ior name": (
        f'<bsdf type="dielectric">\n<string name="int_ior" value="unobtainium"/>{MARK}</bsdf>',
        '<bsdf type="dielectric">', "unknown IOR name"),
    "two constant emitters": (
        f'<emitter type="constant"/>\n<emitter type="constant"/>{MARK}',
        '<emitter type="constant">', "at most one constant"),
    "top-level area emitter": (
        f'<emitter type="area"/>{MARK}', '<emitter type="area">', "nested inside a <shape>"),
    "ellipsoid sphere": (
        f'<shape type="sphere">{MARK}<transform name="to_world"><scale x="2"/></transform></shape>',
        '<shape type="sphere">', "uniformly"),
    "missing mesh": (
        f'<shape type="obj">\n<string name="filename" value="meshes/nothere.obj"/>{MARK}</shape>',
        '<shape type="obj">', os.path.join("meshes", "nothere.obj")),
    "duplicate property": (
        f'<bsdf type="diffuse"><rgb name="reflectance" value="0.1"/>\n'
        f'<rgb name="reflectance" value="0.2"/>{MARK}</bsdf>', '<bsdf type="diffuse">', "given twice"),
    "twosided with two bsdfs": (
        f'<bsdf type="twosided">{MARK}<bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>',
        '<bsdf type="diffuse">', "at most 1"),
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
    "sample border": (
        SENSOR.replace('<rfilter type="box"/>',
                       f'<rfilter type="box"/>\n<boolean name="sample_border" value="true"/>{MARK}'),
        '<film type="hdrfilm">', "sample_border = true is not supported"),
    "crop": (
        SENSOR.replace('<rfilter type="box"/>', f'<rfilter type="box"/>\n<integer name="crop_width" value="8"/>{MARK}'),
        '<film type="hdrfilm">', 'unsupported property "crop_width"'),
    "sampler": (
        SENSOR.replace("</sensor>", f'\n<sampler type="stratified"/>{MARK}</sensor>'),
        '<sampler type="stratified">', "i.i.d."),
    "thinlens": (
        SENSOR.replace('"perspective">', f'"thinlens">{MARK}'), '<sensor type="thinlens">',
        "unsupported sensor"),
    "camera scale": (
        SENSOR.replace("</sensor>", f'\n<transform name="to_world"><scale value="2"/></transform>{MARK}</sensor>')
        .replace("<sensor", f"<sensor"),
        '<sensor type="perspective">', "scale factors"),
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
