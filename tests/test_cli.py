"""The command lines: outputs, headers, and one-line errors with exit code 2."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pathtracer.cli import main
from pathtracer.io.output import read_exr


def run(*args):
    return subprocess.run([sys.executable, "-m", "pathtracer.cli", *args], capture_output=True,
                          text=True, timeout=300)


def test_render_writes_exr_with_mean_variance_and_header_and_a_png(tmp_path):
    out = tmp_path / "cbox.exr"
    code = main(["render", "cornell-box", "-D", "width=16", "-D", "height=16", "--spp", "4",
                 "--seed", "3", "--integrator", "path_nee", "--max-depth", "3", "--processes", "1",
                 "-o", str(out)])
    assert code == 0 and out.exists() and out.with_suffix(".png").exists()
    result = read_exr(out)
    assert result.mean.shape == (16, 16, 3) and result.variance.shape == (16, 16, 3)
    assert result.spp == 4 and result.seed == 3 and result.integrator == "path_nee"
    assert result.options["max_depth"] == 3
    assert result.mean.mean() > 0 and np.all(result.variance >= 0)


def test_render_help_documents_every_option():
    text = run("render", "--help").stdout
    for option in ("-D", "--integrator", "--spp", "--seed", "--max-depth", "--roulette",
                   "--hemisphere", "--branches", "--processes", "-o"):
        assert option in text


@pytest.mark.parametrize("args,needle", [
    (["render", "cornell-box", "--spp", "0", "-o", "x.exr"], "--spp"),
    (["render", "cornell-box", "--integrator", "nope", "-o", "x.exr"], "--integrator"),
    (["render", "cornell-box", "-D", "width", "-o", "x.exr"], "name=value"),
    (["render", "no-such-scene", "-o", "x.exr"], "no-such-scene"),
    (["render", "cornell-box", "--branches", "2", "-o", "x.exr"], "branches"),
])
def test_bad_arguments_give_one_line_and_exit_code_2(args, needle):
    done = run(*args)
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in done.stderr


def test_bad_scene_file_names_file_line_and_plugin(tmp_path):
    scene = tmp_path / "bad.xml"
    scene.write_text('<scene version="3.0.0">\n  <bsdf type="hair"/>\n</scene>\n')
    done = run("render", str(scene), "-o", str(tmp_path / "x.exr"))
    assert done.returncode == 2 and "bad.xml:2" in done.stderr and "hair" in done.stderr


def test_scenes_lists_the_built_in_scenes():
    names = run("scenes").stdout.split()
    assert {"cornell-box", "cornell-caustics", "smallpt", "veach-mis", "mesh", "furnace"} <= set(names)


def test_mitsuba_refs_compare_exit_codes(tmp_path):
    from mitsuba_refs.cli.main import main as refs_main
    assert refs_main(["compare", "no-such-scene"]) == 2
    assert refs_main(["compare", "cornell-box", "-D", "oops"]) == 2


def test_one_rule_for_defines_across_the_command_lines():
    """pathtracer, mitsuba-refs and the experiments split -D the same way (one parser)."""
    import argparse

    from experiments.common import define
    from pathtracer.scene.defines import parse_define, parse_defines
    assert parse_define(" width = 64 ") == ("width", "64")
    assert parse_define("expr=a=b") == ("expr", "a=b") and parse_define("name=") == ("name", "")
    assert parse_defines(["spp=4", "spp=8", "seed=1"]) == {"spp": "8", "seed": "1"}
    assert parse_defines(None) == {}
    for bad in ("width", "=3", " =3"):
        with pytest.raises(ValueError, match="-D expects name=value"):
            parse_define(bad)
        with pytest.raises(argparse.ArgumentTypeError, match="-D expects name=value"):
            define(bad)


def test_scene_names_resolve_to_the_same_file_on_both_sides(tmp_path, monkeypatch):
    """A built-in name, a path with or without .xml: the tracer and mitsuba_refs agree."""
    from mitsuba_refs.reference.config import BUILTIN_SCENES, FEATURE_SCENES, GRADING_SCENES, OWN_TEST_SCENES
    from mitsuba_refs.reference.render import resolve_scene
    from pathtracer.scene.load import builtin_scene_names, scene_file
    scene = tmp_path / "sub" / "mine"
    scene.parent.mkdir()
    scene.write_text("<scene version='3.0.0'/>")
    (tmp_path / "cornell-box").write_text("not the built-in scene")
    monkeypatch.chdir(tmp_path)
    for name in ("cornell-box", "sub/mine", str(scene)):
        assert resolve_scene(name) == Path(scene_file(name)).resolve()
    assert resolve_scene("cornell-box").parent.name == "scenes"
    with pytest.raises(FileNotFoundError, match="did you mean 'cornell-box'"):
        resolve_scene("cornell-bx")
    names = builtin_scene_names()
    assert set(BUILTIN_SCENES) == (set(names) - set(FEATURE_SCENES) - set(OWN_TEST_SCENES)
                                   - set(GRADING_SCENES))
    assert set(GRADING_SCENES) <= set(names) and set(GRADING_SCENES.values()) <= set(BUILTIN_SCENES)
    assert {"cornell-box", "furnace", "smallpt"} <= set(BUILTIN_SCENES) and "materials" not in BUILTIN_SCENES


class _Chosen(Exception):
    """Raised by the stand-in of ``compare``: which integrator the command line chose."""


@pytest.mark.parametrize("scene,expected", [("media-box", "volpath"), ("glass-lamp", "light"),
                                            ("cornell-box", "path")])
def test_compare_tests_the_files_own_integrator_by_default(scene, expected, tmp_path,
                                                           monkeypatch):
    """Without --integrator, ``mitsuba-refs compare`` tests the integrator that renders the
    file's own <integrator> (volpath, ptracer -> light, path), as a user who wrote it expects;
    an explicit --integrator still wins. Nothing is rendered: ``compare`` is replaced."""
    import mitsuba_refs.verdicts.compare
    from mitsuba_refs.cli.main import main as refs_main

    def chosen(scene, integrator, *args, **kwargs):
        raise _Chosen(integrator)

    monkeypatch.setattr(mitsuba_refs.verdicts.compare, "compare", chosen)
    out = ["--out", str(tmp_path / "out")]
    with pytest.raises(_Chosen, match=f"^{expected}$"):
        refs_main(["compare", scene, *out])
    with pytest.raises(_Chosen, match="^path_nee$"):
        refs_main(["compare", scene, "--integrator", "path_nee", *out])
