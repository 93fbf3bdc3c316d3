"""``<include>``, ``<path>`` and the order of ``<default>``s, as Mitsuba 3.9.1 resolves them.

The rules checked here (each was first observed with Mitsuba itself; the
``mitsuba``-marked test repeats the lookup-order experiment live):

- a mesh name is looked up in the top-level file's ``<path>`` folders (the
  last one first), then the scene file's folder, then the working directory;
- an ``<include>`` is looked up relative to the including file first;
- an included file's own ``<path>``s only serve its own ``<include>``s;
- a file is read top to bottom: the first value given to a parameter wins.
"""
from __future__ import annotations

import os

import numpy as np
import pytest

from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene

FILM = ('<film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" '
        'value="$res"/><rfilter type="box"/></film>')
SENSOR = f'<sensor type="perspective"><float name="fov" value="40"/>{FILM}</sensor>'


def write(path, text: str) -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return str(path)


def scene_text(body: str) -> str:
    return f'<scene version="3.0.0">\n{body}\n</scene>\n'


def write_triangle(path, x: float) -> None:
    """A one-triangle PLY whose vertices all have x coordinate ``x`` (tells the files apart)."""
    write(path, "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
                f"end_header\n{x} 0 0\n{x} 1 0\n{x} 0 1\n3 0 1 2\n")


def mesh_x(scene) -> list[float]:
    """The marker x coordinate of every mesh shape, in file order."""
    return [float(scene.tri_p[a:b, 0, 0].mean()) for a, b in scene.shape_prim]


@pytest.fixture
def tree(tmp_path, monkeypatch):
    """scene/, two search folders and a working directory, each with its own m.ply."""
    for folder, x in (("scene", 1), ("pathA", 2), ("pathB", 3), ("cwd", 4)):
        write_triangle(tmp_path / folder / "m.ply", x)
    write_triangle(tmp_path / "pathA" / "only_a.ply", 5)
    write_triangle(tmp_path / "cwd" / "only_cwd.ply", 6)
    write_triangle(tmp_path / "scene" / "frag" / "m_frag.ply", 7)
    monkeypatch.chdir(tmp_path / "cwd")
    return tmp_path


def shape(name: str) -> str:
    return f'<shape type="ply"><string name="filename" value="{name}"/></shape>'


def lookup_scene(tree) -> str:
    write(tree / "scene" / "frag" / "part.xml",
          scene_text(shape("m_frag.ply") + shape("only_cwd.ply")))
    return write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR + shape("m.ply") + shape("only_a.ply") +
        '<include filename="frag/part.xml"/>\n<path value="../pathA"/>\n<path value="../pathB"/>'))


def test_mesh_lookup_order(tree):
    (tree / "scene" / "frag" / "m_frag.ply").rename(tree / "scene" / "m_frag.ply")
    scene = load_scene(lookup_scene(tree))
    # m.ply: the last <path> first (even one written after the shape); only_a.ply: the
    # other <path>; the included file's mesh: the *top* file's folder, not frag/;
    # only_cwd.ply: the working directory, last.
    assert mesh_x(scene) == [3, 5, 7, 6]


def test_included_files_folder_is_not_searched_for_meshes(tree):
    with pytest.raises(SceneError) as info:
        load_scene(lookup_scene(tree))
    message = str(info.value)
    assert message.startswith(os.path.join("frag", "part.xml") + ":2:"), message
    assert 'file not found: "m_frag.ply"' in message


@pytest.mark.mitsuba
def test_mesh_lookup_order_matches_mitsuba(tree, mi):
    (tree / "scene" / "frag" / "m_frag.ply").rename(tree / "scene" / "m_frag.ply")
    path = lookup_scene(tree)
    theirs = sorted(float(np.asarray(sh.vertex_positions_buffer())[0])
                    for sh in mi.load_file(path).shapes())
    assert sorted(mesh_x(load_scene(path))) == theirs


def test_nested_includes_paths_and_parameters(tree):
    """An include relative to the including file; an included <path> that finds a
    deeper include; $params and <default>s shared across files."""
    write(tree / "lib" / "deeper" / "leaf.xml", scene_text(
        '<bsdf type="diffuse" id="grey"><rgb name="reflectance" value="$albedo"/></bsdf>'))
    write(tree / "lib" / "mid.xml", scene_text(
        '<default name="albedo" value="0.25"/><path value="deeper"/><include filename="leaf.xml"/>'))
    path = write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR + '<include filename="../lib/mid.xml"/>'
        '<shape type="ply"><string name="filename" value="m.ply"/><ref id="grey"/></shape>'))
    scene = load_scene(path)
    np.testing.assert_array_equal(scene.bsdfs[0].reflectance, [0.25] * 3)
    assert load_scene(path, albedo=0.5).bsdfs[0].reflectance[0] == 0.5


def test_first_default_wins_in_reading_order(tree):
    write(tree / "scene" / "base.xml", scene_text('<default name="res" value="16"/>' + SENSOR))
    early = write(tree / "scene" / "early.xml", scene_text(
        '<default name="res" value="32"/><include filename="base.xml"/>'))
    late = write(tree / "scene" / "late.xml", scene_text(
        '<include filename="base.xml"/><default name="res" value="32"/>'))
    assert load_scene(early).camera.width == 32
    assert load_scene(late).camera.width == 16  # base.xml's default came first
    assert load_scene(late, res=8).camera.width == 8


def test_parameter_used_before_its_default_is_refused(tree):
    path = write(tree / "scene" / "main.xml", scene_text(SENSOR + '\n<default name="res" value="8"/>'))
    with pytest.raises(SceneError, match=r"main.xml:2: .*\$res.*line 3 comes after"):
        load_scene(path)


def test_include_cycle_is_refused(tree):
    write(tree / "scene" / "a.xml", scene_text('<include filename="b.xml"/>'))
    write(tree / "scene" / "b.xml", scene_text('\n<include filename="a.xml"/>'))
    path = write(tree / "scene" / "main.xml", scene_text('<include filename="a.xml"/>'))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith("b.xml:3: <include>: include cycle main.xml -> a.xml -> b.xml -> a.xml")


def test_errors_inside_included_files_name_that_file(tree):
    write(tree / "scene" / "parts" / "bad.xml", scene_text('\n\n<bsdf type="hair"/>'))
    path = write(tree / "scene" / "main.xml", scene_text('<include filename="parts/bad.xml"/>'))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value).startswith(
        os.path.join("parts", "bad.xml") + ':4: <bsdf type="hair">: unsupported BSDF')


def test_included_files_outside_the_scene_folder_are_named_relative_to_it(tree):
    """``../lib/bad.xml``, not an absolute path (docs/scene-format.md: relative to the
    top-level scene), also for a file included by an included file."""
    write(tree / "lib" / "bad.xml", scene_text('\n\n<bsdf type="hair"/>'))
    write(tree / "lib" / "mid.xml", scene_text('<include filename="bad.xml"/>'))
    for name in ("../lib/bad.xml", "../lib/mid.xml"):
        path = write(tree / "scene" / "main.xml", scene_text(f'<include filename="{name}"/>'))
        with pytest.raises(SceneError) as info:
            load_scene(path)
        assert str(info.value).startswith(
            os.path.join("..", "lib", "bad.xml") + ':4: <bsdf type="hair">: unsupported BSDF')


def fallback_path_scene(tree) -> str:
    """An included file's ``<path value="lib"/>`` that exists only relative to the top-level
    scene's folder (not the included file's), and an include found through it."""
    write(tree / "scene" / "lib" / "leaf.xml", scene_text(shape("m.ply")))
    write(tree / "scene" / "inc" / "part.xml", scene_text('<path value="lib"/>\n'
                                                          '<include filename="leaf.xml"/>'))
    return write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR + '<include filename="inc/part.xml"/>'))


def test_a_path_is_also_resolved_by_the_file_resolver(tree):
    """Mitsuba tries a ``<path>`` relative to its file, then through its file resolver (the
    top-level scene's folder here), as mitsuba-data's docs/scenes/include/*.xml need."""
    assert mesh_x(load_scene(fallback_path_scene(tree))) == [1.0]
    text = (tree / "scene" / "inc" / "part.xml").read_text().replace('"lib"', '"nowhere"')
    (tree / "scene" / "inc" / "part.xml").write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(str(tree / "scene" / "main.xml"))
    message = str(info.value)
    assert message.startswith(os.path.join("inc", "part.xml") + ':2: <path>: folder "nowhere" '
                              "not found (looked for ")
    for folder in (tree / "scene" / "inc" / "nowhere", tree / "scene" / "nowhere"):
        assert str(folder) in message


def test_path_resolution_matches_mitsuba(tree, mi):
    scene = mi.load_file(fallback_path_scene(tree))
    assert len(scene.shapes()) == 1


def test_missing_include_names_the_including_line(tree):
    path = write(tree / "scene" / "main.xml", scene_text('\n<include filename="nothere.xml"/>'))
    with pytest.raises(SceneError, match=r'main.xml:3: <include>: file "nothere.xml" not found'):
        load_scene(path)


def test_area_emitter_defined_at_top_level_and_referenced(tree):
    """Mitsuba's cbox-rgb.xml style: the emitter after the includes, a <ref> in the shape."""
    write(tree / "scene" / "shapes.xml", scene_text(
        '<shape type="ply"><string name="filename" value="m.ply"/><ref id="lamp"/></shape>'))
    path = write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR + '<include filename="shapes.xml"/>'
        '<emitter type="area" id="lamp"><rgb name="radiance" value="2, 3, 4"/></emitter>'))
    scene = load_scene(path)
    assert len(scene.emitters) == 1 and scene.emitters[0].shape == 0
    np.testing.assert_array_equal(scene.emitters[0].radiance, [2, 3, 4])
    assert list(scene.shape_emitter) == [0]


def test_unattached_area_emitter_is_ignored_with_a_warning(tree):
    path = write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR + shape("m.ply") +
        '<emitter type="area" id="lamp"/>'))
    with pytest.warns(UserWarning, match='area emitter "lamp" is not attached'):
        scene = load_scene(path)
    assert scene.emitters == []


def test_include_inside_a_plugin_adds_to_that_plugin(tree):
    """Mitsuba splices the included <scene>'s children into the enclosing element."""
    write(tree / "scene" / "material.xml", scene_text(
        '<bsdf type="diffuse"><rgb name="reflectance" value="0.125"/></bsdf>'))
    path = write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR +
        '<shape type="ply"><string name="filename" value="m.ply"/>'
        '<include filename="material.xml"/></shape>'))
    scene = load_scene(path)
    np.testing.assert_array_equal(scene.bsdfs[scene.shape_bsdf[0]].reflectance, [0.125] * 3)


def include_order_scene(tree) -> str:
    write(tree / "scene" / "mat.xml", scene_text(
        '<bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.25"/></bsdf>'))
    write(tree / "pathA" / "mat.xml", scene_text(
        '<bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.75"/></bsdf>'))
    write(tree / "scene" / "lvl1" / "lvl2" / "b.xml", scene_text('<include filename="c.xml"/>'))
    write(tree / "scene" / "lvl1" / "a.xml", scene_text('<include filename="lvl2/b.xml"/>'))
    write(tree / "scene" / "lvl1" / "c.xml", scene_text(shape("m.ply")))
    return write(tree / "scene" / "main.xml", scene_text(
        '<default name="res" value="8"/>' + SENSOR + '<path value="../pathA"/>'
        '<include filename="mat.xml"/><include filename="lvl1/a.xml"/>'))


def test_include_prefers_the_including_files_folder_to_its_paths(tree):
    """Unlike meshes, an include is tried next to the including file before any <path>;
    an include two levels down still finds a file next to its grandparent."""
    scene = load_scene(include_order_scene(tree))
    assert scene.bsdfs[0].reflectance[0] == 0.25
    assert mesh_x(scene) == [2]  # c.xml's mesh: the top file's <path> first


@pytest.mark.mitsuba
def test_include_order_matches_mitsuba(tree, mi):
    theirs = mi.load_file(include_order_scene(tree))
    np.testing.assert_array_equal(np.asarray(mi.traverse(theirs)["grey.reflectance.value"]), [0.25] * 3)
    assert float(np.asarray(theirs.shapes()[0].vertex_positions_buffer())[0]) == 2


def test_the_reference_key_hashes_the_files_the_loader_reads(tree):
    """The harness's cache key hashes the files found by the loader's own rule: the include
    next to the grandparent (lvl1/c.xml), the mesh in the top file's <path>, the working
    directory's mesh (only_cwd.ply), an included file's mesh by the top file's folders (not
    found there: listed where first looked for, the loader refuses it too)."""
    from mitsuba_refs.reference.cache import included_files
    found = [os.path.relpath(p, tree) for p in included_files(include_order_scene(tree))]
    assert found == ["scene/mat.xml", "scene/lvl1/a.xml", "scene/lvl1/lvl2/b.xml", "scene/lvl1/c.xml",
                     "pathA/m.ply"]
    found = [os.path.relpath(p, tree) for p in included_files(lookup_scene(tree))]
    assert found == ["pathB/m.ply", "pathA/only_a.ply", "scene/frag/part.xml", "pathB/m_frag.ply",
                     "cwd/only_cwd.ply"]
