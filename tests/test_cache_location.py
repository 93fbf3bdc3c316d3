"""Where references are read and written (mitsuba_refs/reference/cache_location.py): the
committed ones first, then the user's cache folder; a reference rendered on demand lands in the
user's cache, never in the package; the first publisher of a reference wins."""
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mitsuba_refs.reference import cache, cache_location, config
from mitsuba_refs.reference.render import Reference, resolve_scene

PARAMS = {"width": "8", "height": "8"}


def fake_reference(value):
    meta = {"scene": "furnace", "width": 8, "height": 8, "spp": 16, "integrator": "path",
            "variant": "none", "mitsuba_version": "test"}
    return Reference(mean=np.full((8, 8, 3), value), var=np.full((8, 8, 3), value / 10), n=16,
                     metadata=meta)


@pytest.fixture
def user_scene(tmp_path):
    path = tmp_path / "scene" / "furnace.xml"
    path.parent.mkdir()
    shutil.copy(resolve_scene("furnace"), path)
    return path


def test_user_cache_is_the_platform_cache_unless_set(monkeypatch, tmp_path):
    monkeypatch.delenv(config.ENV_CACHE, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_location.cache_dir() == tmp_path / "xdg" / "mitsuba-refs"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert cache_location.cache_dir() == Path.home() / ".cache" / "mitsuba-refs"
    monkeypatch.setenv(config.ENV_CACHE, str(tmp_path / "mine"))
    assert cache_location.cache_dir() == tmp_path / "mine"
    package = Path(cache.__file__).resolve().parents[1]
    assert package not in cache_location.cache_dir().resolve().parents


def test_committed_reference_is_found_first(monkeypatch, tmp_path):
    monkeypatch.setenv(config.ENV_CACHE, str(tmp_path / "empty"))
    ref = cache.get_reference("cornell-box", {"width": "64", "height": "64"}, "path",
                              config.REF_SPP, config.REF_SEED, render=False)
    assert Path(ref.metadata["exr_file"]).parent == cache_location.committed_dir()
    assert not (tmp_path / "empty").exists()


def test_rendered_reference_lands_in_the_user_cache(monkeypatch, tmp_path, user_scene):
    user = tmp_path / "user-cache"
    monkeypatch.setenv(config.ENV_CACHE, str(user))
    committed_before = sorted(p.name for p in cache_location.committed_dir().iterdir())
    monkeypatch.setattr(cache, "mitsuba_available", lambda: True)
    monkeypatch.setattr(cache, "render_reference", lambda *a, **k: fake_reference(0.5))
    ref = cache.get_reference(user_scene, PARAMS, "path", 16, 3)
    assert Path(ref.metadata["exr_file"]).parent == user
    assert sorted(p.name for p in cache_location.committed_dir().iterdir()) == committed_before
    # Found again there, without rendering.
    monkeypatch.setattr(cache, "render_reference", None)
    again = cache.get_reference(user_scene, PARAMS, "path", 16, 3, render=False)
    assert np.array_equal(again.mean, ref.mean)


def test_first_publisher_wins(tmp_path, user_scene):
    first = cache.store(fake_reference(0.25), user_scene, PARAMS, "path", 16, 3, tmp_path)
    before = first[0].read_bytes()
    cache.store(fake_reference(0.75), user_scene, PARAMS, "path", 16, 3, tmp_path, replace=False)
    assert first[0].read_bytes() == before
    status, _, ref = cache.validate(user_scene, PARAMS, "path", 16, 3, tmp_path)
    assert status == "ok" and np.all(ref.mean == 0.25)
    assert not list(tmp_path.glob(".*.tmp"))
    # A forced rebuild (mitsuba-refs build --force) replaces it.
    cache.store(fake_reference(0.75), user_scene, PARAMS, "path", 16, 3, tmp_path)
    assert json.loads(first[1].read_text())["key"] == cache.reference_key(
        user_scene, PARAMS, "path", 16, 3)
    assert np.all(cache.validate(user_scene, PARAMS, "path", 16, 3, tmp_path)[2].mean == 0.75)
