"""Files of Mitsuba 0.x, upgraded on load as Mitsuba 3.9.1 upgrades them (pathtracer/scene/upgrade.py).

The rules (Mitsuba's ``transform_upgrade``, src/core/parser.cpp) are checked without Mitsuba;
the ``mitsuba``-marked tests load the same files in Mitsuba and render the committed 0.6
scene with both renderers.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.scene.errors import SceneError
from pathtracer.scene.upgrade import camel_to_underscore, needs_upgrade
from pathtracer.scene.xml import parse_file
from tests.budget import ALPHA

DATA = Path(__file__).parent / "data" / "legacy"
LEGACY_SCENE = DATA / "scene-0.6.xml"
SENSOR = ('<sensor type="perspective"><float name="fov" value="40"/><film type="hdrfilm">'
          '<integer name="width" value="8"/><integer name="height" value="6"/>'
          '<rfilter type="box"/></film></sensor>')


def write(tmp_path, body: str, version: str = "0.5.0", name: str = "old.xml") -> Path:
    path = tmp_path / name
    path.write_text(f'<scene version="{version}">\n{SENSOR}\n{body}\n</scene>\n')
    return path


def only(plugin, kind: str):
    found = [c for c in plugin.children if c.kind == kind]
    assert len(found) == 1, found
    return found[0]


@pytest.mark.parametrize("old, new", [
    ("toWorld", "to_world"), ("intIOR", "int_ior"), ("extIOR", "ext_ior"),
    ("diffuseReflectance", "diffuse_reflectance"), ("maxDepth", "max_depth"),
    ("rrDepth", "rr_depth"), ("shapeIndex", "shape_index"), ("sampleCount", "sample_count"),
    ("fovAxis", "fov_axis"), ("alphaU", "alpha_u"),
    ("specularSamplingWeight", "specular_sampling_weight"),
    ("aBCd", "a_bcd"),           # the capitals after the first join its word
    ("HDRFilm", "HDRFilm"),      # no lower-case letter before the capitals
    ("x2Y", "x2Y"),              # a digit is not lower case
    ("uscale", "uscale"), ("to_world", "to_world"), ("", ""),
])
def test_camel_case_rule(old, new):
    assert camel_to_underscore(old) == new


@pytest.mark.parametrize("version, upgraded", [
    ("0.5.0", True), ("0.6.0", True), ("1.9.9", True), ("2.0.0", False), ("2.1.0", False),
    ("3.0.0", False)])
def test_files_below_2_0_0_are_upgraded(version, upgraded):
    assert needs_upgrade(version) is upgraded


def test_names_of_properties_nested_plugins_and_refs_are_upgraded(tmp_path):
    path = write(tmp_path, """
<texture type="checkerboard" id="tex"/>
<integrator type="path"><integer name="maxDepth" value="3"/></integrator>
<shape type="sphere">
  <transform name="toWorld"><translate x="1"/></transform>
  <bsdf type="roughplastic">
    <texture type="checkerboard" name="diffuseReflectance"/>
    <float name="intIOR" value="1.6"/>
  </bsdf>
</shape>
<shape type="sphere"><bsdf type="diffuse"><ref id="tex" name="diffuseReflectance"/></bsdf></shape>
""")
    root = parse_file(str(path))
    assert set(only(root, "integrator").props) == {"max_depth"}
    first, second = [c for c in root.children if c.kind == "shape"]
    assert set(first.props) == {"to_world"}
    plastic = only(first, "bsdf")
    assert set(plastic.props) == {"int_ior"}
    # Only a diffuse BSDF's diffuse_reflectance becomes reflectance.
    assert [name for name, _ in plastic.named_children()] == ["diffuse_reflectance"]
    assert [name for name, _ in only(second, "bsdf").named_children()] == ["reflectance"]


def test_a_3_x_file_is_not_upgraded_and_the_refusal_says_why(tmp_path):
    path = write(tmp_path, '<shape type="sphere">\n<float name="radius" value="1"/>\n'
                           '<transform name="toWorld"><translate x="1"/></transform></shape>',
                 version="3.0.0")
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    text = str(info.value)
    assert text.startswith('old.xml:5: <shape type="sphere">: unsupported property "toWorld"'), text
    assert 'renames it to "to_world" in files of version below 2.0.0' in text


def test_diffuse_reflectance_as_a_property(tmp_path):
    path = write(tmp_path, '<shape type="sphere"><bsdf type="diffuse">'
                           '<rgb name="diffuseReflectance" value="0.2, 0.4, 0.6"/></bsdf></shape>')
    np.testing.assert_array_equal(load_scene(str(path)).bsdfs[0].reflectance, [0.2, 0.4, 0.6])


@pytest.mark.parametrize("props, want", [
    ('<float name="uscale" value="5"/><float name="vscale" value="3"/>'
     '<float name="uoffset" value="0.25"/><float name="voffset" value="-0.5"/>',
     [[5, 0, 0, 1.25], [0, 3, 0, -1.5], [0, 0, 1, 0], [0, 0, 0, 1]]),
    ('<integer name="uscale" value="4"/>',           # an integer is a number too
     [[4, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]),
    ('<float name="voffset" value="0.5"/>',
     [[1, 0, 0, 0], [0, 1, 0, 0.5], [0, 0, 1, 0], [0, 0, 0, 1]]),
])
def test_uv_offsets_and_scales_become_to_uv(tmp_path, props, want):
    """to_uv = scale(uscale, vscale, 1) @ translate(uoffset, voffset, 0), as Mitsuba writes it."""
    path = write(tmp_path, f'<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
                           f'\n{props}</texture></bsdf>')
    texture = only(only(parse_file(str(path)), "bsdf"), "texture")
    assert set(texture.props) == {"to_uv"}
    np.testing.assert_array_equal(texture.props["to_uv"].value, want)
    assert texture.props["to_uv"].line == 4


@pytest.mark.parametrize("body, line, message", [
    # Mitsuba: 'Property "to_uv" was specified multiple times!'
    ('<float name="uscale" value="2"/>\n<transform name="to_uv"><scale x="3"/></transform>', 5,
     "uscale (Mitsuba 0.x) and to_uv given together"),
    # Mitsuba: 'The property "uscale" has the wrong type (expected float, got string)'
    ('<string name="uscale" value="2"/>', 4, '"uscale" of a Mitsuba 0.x file must be a number'),
])
def test_uv_properties_mitsuba_refuses(tmp_path, body, line, message):
    path = write(tmp_path, f'<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
                           f'\n{body}</texture></bsdf>')
    with pytest.raises(SceneError) as info:
        load_scene(str(path))
    assert str(info.value).startswith(f'old.xml:{line}: <texture type="checkerboard">: {message}')


def test_a_rename_onto_a_given_name_is_skipped(tmp_path):
    """toWorld next to to_world stays toWorld (Mitsuba's rename_property refuses to
    overwrite), and is then refused as unknown."""
    path = write(tmp_path, '<shape type="sphere">\n'
                           '<transform name="to_world"><translate x="1"/></transform>\n'
                           '<transform name="toWorld"><translate x="2"/></transform></shape>')
    assert set(only(parse_file(str(path)), "shape").props) == {"to_world", "toWorld"}
    with pytest.raises(SceneError, match=r'old.xml:5: <shape type="sphere">: unsupported property '
                                         r'"toWorld"'):
        load_scene(str(path))


def test_each_file_is_upgraded_by_its_own_version(tmp_path):
    (tmp_path / "new.xml").write_text(
        '<scene version="3.0.0">\n<shape type="sphere">\n'
        '<transform name="toWorld"><translate x="1"/></transform></shape>\n</scene>\n')
    (tmp_path / "old-part.xml").write_text(
        '<scene version="0.5.0">\n<shape type="sphere">\n'
        '<transform name="toWorld"><translate x="3"/></transform></shape>\n</scene>\n')
    new_top = write(tmp_path, '<include filename="old-part.xml"/>', version="3.0.0", name="a.xml")
    assert load_scene(str(new_top)).sphere_center[0, 0] == 3.0
    old_top = write(tmp_path, '<include filename="new.xml"/>', version="0.5.0", name="b.xml")
    with pytest.raises(SceneError, match=r'^new.xml:3: <shape type="sphere">: unsupported property '
                                         r'"toWorld"'):
        load_scene(str(old_top))


#: scene-0.6.xml written for Mitsuba 3 by hand: the renames of docs/scene-format.md.
MODERN = [("0.6.0", "3.0.0"), ("0.5.0", "3.0.0"), ("toWorld", "to_world"), ("fovAxis", "fov_axis"),
          ("sampleCount", "sample_count"), ("maxDepth", "max_depth"), ("rrDepth", "rr_depth"),
          ("intIOR", "int_ior"), ("extIOR", "ext_ior"),
          ("specularReflectance", "specular_reflectance"),
          ('<rgb name="diffuseReflectance" value="0.6', '<rgb name="diffuse_reflectance" value="0.6'),
          ("diffuseReflectance", "reflectance"),
          ('<float name="uscale" value="5"/>\n                <float name="vscale" value="3"/>\n'
           '                <float name="uoffset" value="0.25"/>',
           '<transform name="to_uv"><translate x="0.25"/><scale x="5" y="3"/></transform>'),
          ("light-0.5.xml", "light-3.xml")]


def test_upgraded_file_renders_as_its_hand_written_mitsuba_3_version(tmp_path):
    for name in ("scene-0.6.xml", "light-0.5.xml"):
        text = (DATA / name).read_text()
        for old, new in MODERN:
            text = text.replace(old, new)
        assert "IOR" not in text and "Depth" not in text and "scale\"" not in text
        (tmp_path / name.replace("0.6", "3").replace("0.5", "3")).write_text(text)
    ours = render(load_scene(LEGACY_SCENE, resolution=(16, 12)), spp=4, seed=3, processes=1)
    theirs = render(load_scene(tmp_path / "scene-3.xml", resolution=(16, 12)), spp=4, seed=3,
                    processes=1)
    np.testing.assert_array_equal(ours.mean, theirs.mean)
    assert ours.mean.max() > 0


@pytest.mark.mitsuba
@pytest.mark.parametrize("body, loads", [
    ('<shape type="sphere"><bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.3"/>'
     '</bsdf></shape>', True),
    ('<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
     '<float name="uscale" value="2"/><transform name="to_uv"><scale x="3"/></transform>'
     '</texture></bsdf>', False),
    ('<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">'
     '<string name="uscale" value="2"/></texture></bsdf>', False),
    ('<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/>'
     '<rgb name="diffuseReflectance" value="0.2"/></bsdf>', False),
])
def test_mitsuba_loads_and_refuses_the_same_files(tmp_path, mi, body, loads):
    path = write(tmp_path, body)
    try:
        mi.load_file(str(path))
        mitsuba_loads = True
    except RuntimeError:   # Mitsuba refuses a file with a RuntimeError
        mitsuba_loads = False
    assert mitsuba_loads is loads
    if loads:
        load_scene(str(path))
    else:
        with pytest.raises(SceneError):
            load_scene(str(path))


@pytest.mark.mitsuba
@pytest.mark.statistical(assertions=2)
def test_upgraded_scene_agrees_with_mitsuba(tmp_path, monkeypatch, mi):
    """The 0.6 file (camelCase, uscale/vscale, an included 0.5 file) rendered by both."""
    from mitsuba_refs.verdicts.compare import compare
    monkeypatch.setenv("MITSUBA_REFS_CACHE", str(tmp_path))
    comparison = compare(str(LEGACY_SCENE), "path", spp=64, alpha=ALPHA, convergence=False,
                         bounces=False, processes=2, resolution=(32, 24))
    assert comparison.mean.agree, comparison.report()
    assert comparison.variance is not None and comparison.variance.agree, comparison.report()
