"""Issue 44, "the first ten minutes": both command lines run as modules, say their version,
end every help page with examples in plain text, say "did you mean" for a misspelt name,
and name the program and the origin of every size in their errors. No Mitsuba needed."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.cli.main import main as refs_main
from mitsuba_refs.cli.main import make_parser
from pathtracer import __version__
from pathtracer.cli import build_parser
from pathtracer.core.cli_help import with_choice_hint
from pathtracer.core.names import did_you_mean, suggestion
from pathtracer.scene.errors import SceneError
from pathtracer.scene.load import load_scene

ROOT = Path(__file__).resolve().parent.parent


def _module(name, *args):
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    return subprocess.run([sys.executable, "-m", name, *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("module, prog", [("pathtracer", "pathtracer"), ("mitsuba_refs", "mitsuba-refs")])
def test_python_m_runs_the_command_and_says_its_version(module, prog):
    done = _module(module, "--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"{prog} {__version__}"


def test_the_version_is_the_installed_distributions():
    from importlib.metadata import PackageNotFoundError, version
    try:
        installed = version("pathtracer-validation")
    except PackageNotFoundError:
        pytest.skip("the package is not installed (pip install -e .)")
    assert installed == __version__


def _help_pages(parser):
    """(prog, help text) of ``parser`` and of each of its subcommands."""
    yield parser.prog, parser.format_help()
    for action in parser._subparsers._group_actions:
        for command in action.choices.values():
            yield command.prog, command.format_help()


@pytest.mark.parametrize("parser", [build_parser(), make_parser()], ids=["pathtracer", "mitsuba-refs"])
def test_every_help_page_has_examples_in_plain_text(parser):
    pages = dict(_help_pages(parser))
    assert len(pages) >= 3
    for prog, text in pages.items():
        assert "example" in text.lower(), f"{prog} --help has no example"
        assert "``" not in text, f"{prog} --help shows reStructuredText"
        assert f"\n  {prog.split()[0]} " in text, f"{prog} --help: the examples are not shown as written"


def test_help_keeps_example_lines_whole_and_wraps_prose():
    text = make_parser().format_help()
    assert "  mitsuba-refs compare cornell-box --integrator path_nee\n" in text
    first = build_parser().format_help().splitlines()[2]
    assert first.startswith("pathtracer: render Mitsuba 3 scene files")


def test_did_you_mean_finds_a_misspelling_and_only_one():
    names = ["cornell-box", "cornell-caustics", "veach-mis"]
    assert did_you_mean("cornel-box", names) == "cornell-box"
    assert did_you_mean("Cornell-Box", names) == "cornell-box"
    assert did_you_mean("xyz", names) is None
    assert suggestion("xyz", names) == ""
    assert suggestion("veach_mis", names) == "did you mean 'veach-mis'? "


def test_argparse_choice_errors_say_did_you_mean():
    message = "argument --integrator: invalid choice: 'pth' (choose from 'bdpt', 'path', 'path_nee')"
    assert with_choice_hint(message).endswith("; did you mean 'path'?")
    assert with_choice_hint("argument --spp: expected a number") == "argument --spp: expected a number"


def test_compare_misspelt_integrator_says_did_you_mean(capsys):
    with pytest.raises(SystemExit) as stop:
        refs_main(["compare", "cornell-box", "--integrator", "path_ne"])
    err = capsys.readouterr().err
    assert stop.value.code == 2
    assert err.startswith("mitsuba-refs compare: error:") and "did you mean 'path_nee'?" in err


def test_misspelt_subcommand_says_did_you_mean(capsys):
    with pytest.raises(SystemExit):
        refs_main(["comapre", "cornell-box"])
    assert "did you mean 'compare'?" in capsys.readouterr().err


@pytest.mark.parametrize("source", [["--command", "render {scene} {spp} {seed} {out}"], ["--images", "x.exr"]])
def test_check_misspelt_scene_names_the_program_and_the_scene(capsys, source):
    code = refs_main(["check", "cornel-box", *source])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("mitsuba-refs check: error: cornel-box: no such file"), err
    assert "did you mean 'cornell-box'?" in err
    assert "None" not in err and "{scene}" not in err


def test_scene_plugins_and_presets_say_did_you_mean(tmp_path):
    scene = tmp_path / "s.xml"
    sensor = '<sensor type="perspective"><film type="hdrfilm"/></sensor>'
    scene.write_text(f'<scene version="3.0.0"><integrator type="pth"/>{sensor}<shape type="sphere"/></scene>')
    with pytest.raises(SceneError, match="did you mean 'path'"):
        load_scene(scene)
    scene.write_text(f'<scene version="3.0.0">{sensor}<shape type="sphere"><bsdf type="conductor">'
                     '<string name="material" value="Aul"/></bsdf></shape></scene>')
    with pytest.raises(SceneError, match="did you mean 'Au'"):
        load_scene(scene)


def _pfm(path, width, height):
    with open(path, "wb") as out:
        out.write(f"PF\n{width} {height}\n-1.0\n".encode())
        out.write(np.full((height, width, 3), 0.5, np.float32).tobytes())
    return str(path)


def test_images_of_the_wrong_size_are_told_where_the_film_size_came_from(capsys, tmp_path):
    image = _pfm(tmp_path / "big.pfm", 256, 256)
    code = refs_main(["check", "cornell-box", "--images", image, "--spp", "4"])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("mitsuba-refs check: error:")
    assert "the image is 256x256, the scene's film is 64x64 (the built-in scene's test size" in err
    assert "--resolution 256x256" in err
    code = refs_main(["check", "cornell-box", "--images", image, "--spp", "4", "-D", "width=32"])
    assert "film is 32x64 (from -D width/height" in capsys.readouterr().err


def test_images_without_a_sample_count_name_the_file_the_program_and_spp(capsys, tmp_path):
    image = _pfm(tmp_path / "no_spp.pfm", 64, 64)
    code = refs_main(["check", "cornell-box", "--images", image])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith(f"mitsuba-refs check: error: {image}: no sample count"), err
    assert "--spp N" in err


def test_too_small_an_image_names_resolution(capsys):
    code = refs_main(["compare", "cornell-box", "--resolution", "8x8", "--no-convergence"])
    err = capsys.readouterr().err
    assert code == 2 and "--resolution 32x32" in err, err


def test_the_fixtures_install_route_brings_pytest():
    import tomllib
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert any(req.startswith("pytest") for req in project["optional-dependencies"]["pytest"])
    assert 'pip install -e ".[pytest]"' in (ROOT / "docs" / "external.md").read_text()


def test_python_m_is_the_command_for_the_one_line_interrupt(monkeypatch):
    from pathtracer import _console
    monkeypatch.setattr(sys, "argv", ["-m"])
    monkeypatch.setattr(sys, "orig_argv", [sys.executable, "-m", "mitsuba_refs", "compare"], raising=False)
    assert _console.command_name() == "mitsuba-refs"
    monkeypatch.setattr(sys, "orig_argv", [sys.executable, "-m", "pytest"], raising=False)
    assert _console.command_name() is None
    monkeypatch.setattr(sys, "argv", ["/venv/bin/pathtracer", "render"])
    assert _console.command_name() == "pathtracer"


def test_a_files_sample_count_out_of_range_names_the_file_and_spp(tmp_path, capsys):
    from pathtracer.cli import main as pathtracer_main
    scene = tmp_path / "big.xml"
    scene.write_text('<scene version="3.0.0"><sensor type="perspective">'
                     '<sampler type="independent"><integer name="sample_count" value="99999999999"/></sampler>'
                     '<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>'
                     '</film></sensor><shape type="sphere"/></scene>')
    assert pathtracer_main(["render", str(scene), "-o", str(tmp_path / "x.exr")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"pathtracer: error: {scene}: the file's <sampler> sample_count") and "--spp N" in err
