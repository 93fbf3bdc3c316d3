"""Tests of the reference side (mitsuba_refs).

Parts that need a live Mitsuba are marked ``mitsuba`` and skipped with a
reason when it is missing. Statistical tests use the library's mean test,
:func:`mitsuba_refs.stats.compare_means` (8 x 8 tiles and the whole image), at the
suite's per-test level ``tests.budget.ALPHA``. They are not counted in the suite's
error budget (marker ``statistical``): their inputs are fixed (committed references,
fixed seeds), so each passes or fails the same way on every run, whatever the tracer.
"""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from mitsuba_refs.reference import config
from mitsuba_refs.reference.cache import ReferenceUnavailable, get_reference, store, validate
from mitsuba_refs.reference.exr import write_reference_exr
from mitsuba_refs.reference.render import Reference, resolve_scene
from mitsuba_refs.report.wording import verdict_line
from mitsuba_refs.stats import compare_means
from pathtracer.io.exr import read_mean_variance as read_reference_exr
from tests.budget import ALPHA

REPO = Path(__file__).resolve().parent.parent

# --------------------------------------------------------------- helpers

def assert_same_mean(a, b, what):
    """The library's mean test (tiles + image) at the suite's level: a and b agree."""
    agreement = compare_means(a.mean, a.var, a.n, b.mean, b.var, b.n, alpha=ALPHA)
    assert agreement, f"{what}: {verdict_line(agreement)}"


def fake_reference(h=8, w=8, seed=0):
    rng = np.random.default_rng(seed)
    mean = rng.random((h, w, 3))
    var = rng.random((h, w, 3))
    meta = {"scene": "furnace", "width": w, "height": h, "spp": 16,
            "integrator": "path", "variant": "none", "mitsuba_version": "test"}
    return Reference(mean=mean, var=var, n=16, metadata=meta)


@pytest.fixture
def scene_copy(tmp_path):
    """A private copy of furnace.xml (safe to edit)."""
    dst = tmp_path / "scene" / "furnace.xml"
    dst.parent.mkdir()
    shutil.copy(resolve_scene("furnace"), dst)
    return dst


PARAMS = {"width": "8", "height": "8"}


# ------------------------------------------------- cache (no Mitsuba needed)

def test_exr_roundtrip(tmp_path):
    ref = fake_reference()
    write_reference_exr(tmp_path / "a.exr", ref.mean, ref.var, {"spp": 16, "integrator": "path"})
    mean, var, attrs = read_reference_exr(tmp_path / "a.exr")
    assert np.allclose(mean, ref.mean.astype(np.float32))
    assert np.allclose(var, ref.var.astype(np.float32))
    assert attrs["spp"] == 16 and attrs["integrator"] == "path"


def test_cache_roundtrip(scene_copy, tmp_path):
    ref = fake_reference()
    store(ref, scene_copy, PARAMS, "path", 16, 3, directory=tmp_path)
    status, detail, loaded = validate(scene_copy, PARAMS, "path", 16, 3, directory=tmp_path)
    assert status == "ok", detail
    assert np.allclose(loaded.mean, ref.mean, atol=1e-6)
    assert np.allclose(loaded.var, ref.var, atol=1e-6)
    assert loaded.n == 16
    # get_reference returns it without rendering
    again = get_reference(scene_copy, PARAMS, "path", 16, 3, directory=tmp_path, render=False)
    assert np.array_equal(again.mean, loaded.mean)
    # recursive / smallpt share path's reference
    assert validate(scene_copy, PARAMS, "smallpt", 16, 3, directory=tmp_path)[0] == "ok"


def test_missing_raises_clear_error(scene_copy, tmp_path):
    with pytest.raises(ReferenceUnavailable, match="missing"):
        get_reference(scene_copy, PARAMS, "path", 16, 3, directory=tmp_path, render=False)


@pytest.mark.parametrize("change", ["scene", "params", "integrator", "spp", "seed"])
def test_stale_detected(scene_copy, tmp_path, change):
    store(fake_reference(), scene_copy, PARAMS, "path", 16, 3, directory=tmp_path)
    args = dict(scene=scene_copy, params=dict(PARAMS), integrator="path", spp=16, seed=3)
    if change == "scene":
        scene_copy.write_text(scene_copy.read_text().replace(
            '<default name="albedo" value="0.5"/>', '<default name="albedo" value="0.6"/>'))
        # A user's reference is named by the scene's content: the changed file has none yet.
        status = validate(**args, directory=tmp_path)[0]
        assert status == "missing"
        with pytest.raises(ReferenceUnavailable, match="missing"):
            get_reference(**args, directory=tmp_path, render=False)
        return
    if change == "params":
        args["params"]["albedo"] = "0.7"
    elif change == "integrator":
        args["integrator"] = "path_nee"
    elif change == "spp":
        args["spp"] = 32
    elif change == "seed":
        args["seed"] = 4
    # a different identity never returns the old file's pixels
    assert validate(**args, directory=tmp_path)[0] != "ok"


def test_stale_when_included_mesh_changes(tmp_path):
    d = tmp_path / "scene"
    d.mkdir()
    shutil.copy(resolve_scene("mesh"), d / "mesh.xml")
    shutil.copy(resolve_scene("mesh").parent / "mesh-bumpy-sphere.ply", d)
    store(fake_reference(), d / "mesh.xml", PARAMS, "path", 16, 3, directory=tmp_path)
    assert validate(d / "mesh.xml", PARAMS, "path", 16, 3, directory=tmp_path)[0] == "ok"
    ply = d / "mesh-bumpy-sphere.ply"
    data = bytearray(ply.read_bytes())
    data[-1] ^= 1
    ply.write_bytes(bytes(data))
    # Named by the scene's and its files' content: the changed mesh makes another reference.
    assert validate(d / "mesh.xml", PARAMS, "path", 16, 3, directory=tmp_path)[0] == "missing"


@pytest.mark.parametrize("damage", ["truncate", "nan", "shape", "pixels", "sidecar"])
def test_corrupt_detected(scene_copy, tmp_path, damage):
    ref = fake_reference()
    exr, sidecar = store(ref, scene_copy, PARAMS, "path", 16, 3, directory=tmp_path)
    meta = json.loads(sidecar.read_text())
    if damage == "truncate":
        exr.write_bytes(exr.read_bytes()[:200])
    elif damage == "nan":
        mean = ref.mean.copy()
        mean[2, 3, 1] = np.nan
        _, _, attrs = read_reference_exr(exr)
        write_reference_exr(exr, mean, ref.var, {k: attrs[k] for k in ("key",)})
    elif damage == "shape":
        meta["width"] = 16
        sidecar.write_text(json.dumps(meta))
    elif damage == "pixels":
        _, _, attrs = read_reference_exr(exr)
        keep = {k: v for k, v in attrs.items() if k in ("key", "spp")}
        write_reference_exr(exr, ref.mean * 1.01, ref.var, keep)
    elif damage == "sidecar":
        sidecar.write_text("{not json")
    status, detail, loaded = validate(scene_copy, PARAMS, "path", 16, 3, directory=tmp_path)
    assert status == "corrupt", detail
    assert loaded is None
    with pytest.raises(ReferenceUnavailable, match="corrupt"):
        get_reference(scene_copy, PARAMS, "path", 16, 3, directory=tmp_path, render=False)


# ------------------------------------------------------ committed references

def committed(scene, integrator, **extra):
    w, h = config.test_resolution(scene)
    params = {"width": str(w), "height": str(h), **{k: str(v) for k, v in extra.items()}}
    status, detail, ref = validate(scene, params, integrator, config.REF_SPP, config.REF_SEED,
                                   directory=REPO / "mitsuba_refs" / "references")
    # Committed references ship with the repository: a missing one is a defect, not a skip.
    assert status == "ok", f"{scene}/{integrator}: {status} ({detail}); run mitsuba-refs build"
    return ref


def test_committed_reference_loads_without_mitsuba():
    code = (
        "import sys; sys.modules['mitsuba'] = None; sys.modules['drjit'] = None\n"
        "from mitsuba_refs import get_reference\n"
        "from mitsuba_refs.reference import config\n"
        "r = get_reference('cornell-box', {'width': '64', 'height': '64'}, 'path',"
        " config.REF_SPP, config.REF_SEED, render=False)\n"
        "print(r.n, r.mean.shape)\n")
    env = dict(os.environ, PYTHONPATH=str(REPO))
    env.pop(config.ENV_CACHE, None)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env=env, cwd=REPO)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[0] == str(config.REF_SPP)


def _scenes_for(integrator):
    # The furnace is checked against its analytic value instead (test_committed_furnace_analytic):
    # Mitsuba 3.9.1's own `path` is biased there (+0.16 %, tests/test_mitsuba_known_bias.py).
    scenes = [s for s in config.BUILTIN_SCENES if s != "furnace"]
    if integrator == "path_bsdf":
        scenes.remove("point-light")  # point lights cannot be hit
        scenes.remove("spot-directional")  # nor spot and directional lights (only its sky is seen)
    return scenes


@pytest.mark.parametrize("scene,integrator", [(s, i) for i in ("path_bsdf", "path_nee")
                                               for s in _scenes_for(i)])
def test_committed_lecture_refs_agree_with_path(scene, integrator):
    """The lecture estimators' references have the same mean as ``path``'s."""
    a, b = committed(scene, integrator), committed(scene, "path")
    assert_same_mean(a, b, scene)


@pytest.mark.parametrize("integrator", ["path_bsdf", "path_nee"])
def test_committed_furnace_analytic(integrator):
    """Furnace (rho = 0.5, Le = 1): L = Le / (1 - rho) = 2 in every pixel."""
    ref = committed("furnace", integrator)
    n_total = ref.n * ref.mean[..., 0].size
    z = (ref.mean.mean() - 2.0) / np.sqrt(ref.var.mean() / n_total)
    assert abs(z) < stats.norm.isf(ALPHA / 2), f"z = {z:.2f}, mean {ref.mean.mean():.5f}"


@pytest.mark.parametrize("scene", config.BUILTIN_SCENES)
def test_committed_direct_equals_path_depth2(scene):
    a, b = committed(scene, "direct"), committed(scene, "path", max_depth=2)
    assert_same_mean(a, b, scene)


def test_per_bounce_localisation_finds_the_committed_references_with_rr_depth(monkeypatch):
    """A comparison run with ``-D rr_depth=8`` (as the grader's glass checks are) localises a
    failure against the committed per-bounce references: at max_depth 1-3 no roulette acts
    with rr_depth 8 nor with the file's 5, so they are the same estimator. With rr_depth 2,
    roulette acts at max_depth 3 only, and only that reference keeps rr_depth in its key."""
    import mitsuba_refs.verdicts.compare as compare
    from mitsuba_refs.settings import Settings
    from mitsuba_refs.verdicts.scenes import default_params, render_ours
    seen = []

    def committed_only(scene, params, *args, strip=False, **kwargs):
        seen.append(params.get("rr_depth"))
        if strip:     # the reference with roulette at depth 3 is not committed: stand in
            params = {k: v for k, v in params.items() if k != "rr_depth"}
        return get_reference(scene, params, *args, render=False, **kwargs)

    params = {**default_params("glass-cube"), "rr_depth": 8}
    monkeypatch.setattr(compare, "get_reference", committed_only)
    quick = Settings(spp=4, alpha=1e-3, processes=1)
    found = compare.localise_bounce("glass-cube", "path", params, quick, render_ours)
    assert sorted(found) == [1, 2, 3] and seen == [None, None, None]
    seen.clear()
    monkeypatch.setattr(compare, "get_reference",
                        lambda *a, **k: committed_only(*a, strip=True, **k))
    compare.localise_bounce("glass-cube", "path", {**params, "rr_depth": 2}, quick, render_ours)
    assert seen == [None, None, 2]


# ------------------------------------------------------ live Mitsuba tests

@pytest.fixture(scope="module")
def mi_variant(mi):
    """The variant references are rendered in here; ``scalar_rgb`` again after the module."""
    from mitsuba_refs.reference.variant import set_variant
    variant, _ = set_variant()
    yield variant
    mi.set_variant("scalar_rgb")


def _spp(variant, jit, scalar):
    return jit if variant != "scalar_rgb" else scalar


@pytest.mark.mitsuba
def test_variant_choice_and_override(monkeypatch):
    from mitsuba_refs.reference.variant import choose_variant
    v, reason = choose_variant("scalar_rgb")
    assert v == "scalar_rgb" and "explicit" in reason
    monkeypatch.setenv(config.ENV_VARIANT, "scalar_rgb")
    assert choose_variant()[0] == "scalar_rgb"
    monkeypatch.delenv(config.ENV_VARIANT)
    v, reason = choose_variant()
    assert v in ("llvm_ad_rgb", "scalar_rgb") and reason


@pytest.mark.mitsuba
def test_moment_mean_equals_path_render(mi_variant):
    import mitsuba as mi

    from mitsuba_refs.reference import moments
    scene = mi.load_file(str(resolve_scene("cornell-box")), width=32, height=32)
    spp = 16
    plain = np.array(mi.render(scene, integrator=mi.load_dict({"type": "path"}), spp=spp, seed=7))
    mi.render(scene, integrator=mi.load_dict(moments.moment_dict({"type": "path"})),
              spp=spp, seed=7)
    m1, m2 = moments.read_moments(scene.sensors()[0].film())
    assert np.allclose(m1, plain[..., :3], rtol=1e-5, atol=1e-5)
    assert np.all(m2 >= m1 * m1 - 1e-4)


@pytest.mark.mitsuba
def test_moment_variance_furnace(mi_variant):
    """Furnace, BSDF sampling, roulette from depth 1 (q = rho, weight 1):
    the number of emitter hits is 1 + Geometric, mean 1/(1-rho), per-sample
    variance rho/(1-rho)^2 = 2 for rho = 0.5; without roulette and with
    max_depth D all samples equal (1 - rho^D)/(1 - rho): zero variance."""
    from mitsuba_refs.reference.render import render_reference
    spp = _spp(mi_variant, 256, 32)
    ref = render_reference("furnace", {"width": 32, "height": 32, "rr_depth": 1},
                           "path_bsdf", spp, 5, variant=mi_variant)
    n_pix = ref.mean[..., 0].size
    # mean over pixels of the sample variance: sd ~ sqrt(mu4 - s^4)/sqrt(N)
    assert abs(ref.mean.mean() - 2.0) < 5 * np.sqrt(2.0 / (spp * n_pix))
    assert abs(ref.var.mean() - 2.0) < 0.15 * (256 / spp) ** 0.5
    ref = render_reference("furnace", {"width": 32, "height": 32, "max_depth": 3,
                                       "rr_depth": 100}, "path_bsdf", 8, 5, variant=mi_variant)
    assert np.allclose(ref.mean, 1.75, atol=1e-5)
    assert np.all(ref.var < 1e-9)


@pytest.mark.mitsuba
@pytest.mark.parametrize("integrator", ["path_bsdf", "path_nee"])
def test_lecture_integrators_mean_agrees_with_path_live(mi_variant, integrator):
    """Live render on the Cornell box: each lecture estimator vs ``path``."""
    from mitsuba_refs.reference.render import render_reference
    spp = _spp(mi_variant, 512, 16)
    size = 64 if mi_variant != "scalar_rgb" else 32
    params = {"width": size, "height": size}
    a = render_reference("cornell-box", params, integrator, spp, 11, variant=mi_variant)
    b = render_reference("cornell-box", params, "path", spp, 12, variant=mi_variant)
    assert_same_mean(a, b, f"cornell-box, {integrator} vs path")


@pytest.mark.mitsuba
def test_unsupported_filter_refused(tmp_path, mi_variant):
    from mitsuba_refs.reference.render import render_reference
    src = resolve_scene("furnace").read_text().replace('<rfilter type="box"/>',
                                                         '<rfilter type="lanczos"/>')
    (tmp_path / "g.xml").write_text(src)
    with pytest.raises(ValueError, match="lanczos"):
        render_reference(tmp_path / "g.xml", {}, "path", 4, 0, variant=mi_variant)


def test_committed_bsdf_sampling_ref_of_point_light_is_black():
    """BSDF sampling can never hit a point light: Mitsuba's lecture_path_bsdf image is black."""
    ref = committed("point-light", "path_bsdf")
    assert not ref.mean.any() and not ref.var.any()


def test_reference_names_are_unique_per_content(tmp_path, monkeypatch):
    """Four users' different ``scene.xml`` in four folders get four references; one file
    reached by two spellings of its path, or a copy of it elsewhere (another machine of a
    cluster), gets one; built-in scenes keep their readable names."""
    from mitsuba_refs.reference.cache import reference_stem
    from pathtracer.scene.load import builtin_scene_path

    files = []
    for folder in "abcd":
        (tmp_path / folder).mkdir()
        files.append(tmp_path / folder / "scene.xml")
        shutil.copy(builtin_scene_path("quad-light"), files[-1])
    assert len({reference_stem(file, {}, "path", 16, 1) for file in files}) == 1
    for n, file in enumerate(files):
        file.write_text(file.read_text() + f"<!-- user {n} -->\n")
    stems = {reference_stem(file, {}, "path", 16, 1) for file in files}
    assert len(stems) == 4 and all(stem.startswith("scene-") for stem in stems)
    monkeypatch.chdir(tmp_path / "a")
    assert reference_stem("scene.xml", {}, "path", 16, 1) == reference_stem(files[0], {}, "path", 16, 1)
    assert reference_stem("../a/./scene.xml", {}, "path", 16, 1) == reference_stem(files[0], {}, "path", 16, 1)
    assert reference_stem("quad-light", {}, "path", 16, 1) == "quad-light__path__16spp-s1"
    committed = {p.stem for p in Path(config.__file__).parent.joinpath("references").glob("*.json")}
    builtin = {stem.split("__")[0] for stem in committed}
    assert all(os.path.isfile(builtin_scene_path(name)) for name in builtin)
