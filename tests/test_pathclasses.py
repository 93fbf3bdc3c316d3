"""Heckbert path classes: the regex -> DFA compiler and the class-splitting integrator."""
import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.integrators.pathclass import PathClassIntegrator
from pathtracer.pathclasses import (PathRegexError, bsdf_letter, compile_class, describe_letters,
                                    is_partition)
from pathtracer.render import render_classes

PARTITION = ["LE", "LDE", "LD.+E", "LS.*E", "LG.*E"]


@pytest.mark.parametrize("expression, inside, outside", [
    ("LDE", ["LDE"], ["LE", "LDDE", "LSE", "LGE"]),
    ("LDD+E", ["LDDE", "LDDDDE"], ["LDE", "LSDE", "LDSE"]),
    ("LS+DE", ["LSDE", "LSSSDE"], ["LDE", "LSE", "LDSDE"]),
    ("LS*E", ["LE", "LSE", "LSSSE"], ["LDE", "LSDE"]),
    ("L(D|S)*E", ["LE", "LDSDSE", "LSSE"], ["LGE", "LDGE"]),
    ("L.*E", ["LE", "LGDSE"], ["LEE", "DE"]),
    ("L[DG]?S E", ["LSE", "LDSE", "LGSE"], ["LSSE", "LE"]),
    ("LDS*E", ["LDE", "LDSSE"], ["LSDE"]),
])
def test_classes_match_heckbert_strings(expression, inside, outside):
    cls = compile_class(expression)
    for path in inside:
        assert cls.matches(path), (expression, path)
    for path in outside:
        assert not cls.matches(path), (expression, path)


def test_dfa_reads_paths_from_the_eye():
    """The automaton is of the reversed expression: E first, L last."""
    cls = compile_class("LS+DE")
    state = cls.step(np.array([cls.start]), "E")
    for letter in "DSS":
        state = cls.step(state, letter)
    assert cls.accept[cls.step(state, "L")].all()


@pytest.mark.parametrize("bad", ["", "L(DE", "LD)E", "LXE", "*LE", "L[]E"])
def test_malformed_expressions_are_reported(bad):
    with pytest.raises(PathRegexError):
        compile_class(bad)


def test_partition_checker():
    assert is_partition(PARTITION)[0]
    assert is_partition(["LE", "L.E", "L..E", "L...+E"])[0]
    ok, why = is_partition(["LE", "LDE", "L.+E"])
    assert not ok and "LDE" in why


def test_bsdf_letters_and_glossy_folding():
    scene = load_scene("veach-mis", width=8, height=6)
    letters = {bsdf_letter(b) for b in scene.bsdfs}
    assert letters == {"D", "G"}
    folded = {bsdf_letter(b, 0.07) for b in scene.bsdfs}
    assert folded == {"D", "S"}          # alpha 0.01, 0.05 -> S; 0.1, 0.3 -> D
    assert all("->" in line for line in describe_letters(scene))
    caustics = load_scene("cornell-caustics", width=8, height=8)
    assert {bsdf_letter(b) for b in caustics.bsdfs} == {"D", "S"}


@pytest.mark.parametrize("scene_name", ["cornell-caustics", "veach-mis"])
def test_partition_sums_to_the_path_image(scene_name):
    """Same seed: 'L.*E' is the path image bit for bit, and a partition adds up to it."""
    scene = load_scene(scene_name, width=16, height=12)
    full = render(scene, "path", spp=4, seed=5, processes=1, progress=False)
    result = render_classes(scene, ["L.*E"] + PARTITION, spp=4, seed=5, processes=1)
    assert np.array_equal(result["mean"][0], full.mean)
    summed = result["mean"][1:].sum(axis=0)
    assert np.allclose(summed, full.mean, rtol=1e-12, atol=1e-12)
    assert result["mean"][1:].min() >= 0


def test_bounce_classes_partition_the_path_image():
    scene = load_scene("cornell-box", width=12, height=12)
    full = render(scene, "path", spp=3, seed=2, processes=1, progress=False)
    result = render_classes(scene, ["LE", "L.E", "L..E", "L...+E"], spp=3, seed=2, processes=2,
                            batch_size=64)
    assert np.allclose(result["mean"].sum(axis=0), full.mean, rtol=1e-12, atol=1e-12)
    depth2 = render(scene, "path", spp=3, seed=2, processes=1, progress=False, max_depth=2)
    assert np.allclose(result["mean"][:2].sum(axis=0), depth2.mean, rtol=1e-12, atol=1e-12)


def test_single_class_through_the_ordinary_renderer():
    scene = load_scene("cornell-caustics", width=12, height=12)
    caustics = render(scene, PathClassIntegrator("LS+DE"), spp=4, seed=1, processes=1, progress=False)
    split = render_classes(scene, ["LS+DE"], spp=4, seed=1)
    assert np.array_equal(caustics.mean, split["mean"][0])
    assert caustics.options["classes"] == ["LS+DE"]
