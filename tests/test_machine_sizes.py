"""Sizes chosen from the machine at run time (issue 28): what the machine reports, the batch
and all-pairs chunk chosen from it, and images that do not depend on either."""
import numpy as np
import pytest

from pathtracer import load_scene, render
from pathtracer.accel import small_mesh
from pathtracer.cli import main
from pathtracer.core import machine
from pathtracer.render import resources, sizes


def _cache(folder, name, level, kind, size, shared="0-1"):
    index = folder / name
    index.mkdir(parents=True)
    for file, text in (("level", f"{level}\n"), ("type", f"{kind}\n"), ("size", f"{size}\n"),
                       ("shared_cpu_list", f"{shared}\n")):
        (index / file).write_text(text)


def test_caches_are_read_from_sysfs_instruction_caches_and_broken_entries_left_out(tmp_path):
    _cache(tmp_path, "index0", 1, "Data", "48K", "0")
    _cache(tmp_path, "index1", 1, "Instruction", "32K", "0")
    _cache(tmp_path, "index2", 2, "Unified", "2048K", "0")
    _cache(tmp_path, "index3", 3, "Unified", "260M", "0-3,8-9")
    _cache(tmp_path, "index4", 4, "Unified", "lots")
    assert machine.read_caches(tmp_path) == {"L1d": (48 << 10, 1), "L2": (2 << 20, 1),
                                             "L3": (260 << 20, 6)}
    assert machine.read_caches(tmp_path / "missing") == {}


def test_cpu_model_and_description(tmp_path):
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nmodel name\t: Intel(R) Xeon(R) Processor\nflags\t: avx\n")
    assert machine.cpu_model(cpuinfo) == "Intel(R) Xeon(R) Processor"
    assert machine.cpu_model(tmp_path / "none") == "unknown CPU"
    box = machine.Machine("AMD EPYC", 2, L1d=32 << 10, L2=512 << 10, L3=None)
    assert box.describe() == "AMD EPYC, 2 cores, L1d 32 KB, L2 512 KB per core, L3 unknown"


def test_this_machine_reports_caches_that_the_kernel_knows():
    here = machine.this_machine()
    assert here.cores >= 1 and here.cpu
    found = machine.read_caches(machine.CACHE_FOLDER) or machine.sysconf_caches()
    assert here.L2 == found.get("L2", (None,))[0]


@pytest.mark.parametrize("available, processes, expected", [
    (None, 2, sizes.BATCH_CAP),          # unknown memory: the cap
    (16 << 30, 2, sizes.BATCH_CAP),      # plenty: the cap
    (256 << 20, 2, 1 << 14),             # 2 x 16k x 1.8 KB = 60 MB <= 64 MB, 32k is not
    (256 << 20, 1, 1 << 15),
    (64 << 20, 4, sizes.BATCH_FLOOR),    # short of memory: never below the floor
])
def test_the_batch_is_the_largest_power_of_two_within_the_memory_share(available, processes,
                                                                        expected):
    chosen = sizes.choose_batch(processes, available)
    assert chosen.paths == expected
    per_path = resources.BYTES_PER_PATH + resources.BYTES_PER_UNIT_SAMPLE
    if available is not None and expected > sizes.BATCH_FLOOR:
        budget = available * sizes.MEMORY_SHARE / processes
        assert expected * per_path <= budget < 2 * expected * per_path or expected == sizes.BATCH_CAP
    assert str(processes) in chosen.reason or available is None


def test_the_all_pairs_chunk_fills_the_l2_within_its_range():
    low, high = small_mesh.SMALL_CHUNK_RANGE
    assert small_mesh.chunk_rays(202, 2 << 20)[0] == high          # 1.6 MB within 2 MB
    assert small_mesh.chunk_rays(550, 2 << 20)[0] == 2048          # 1.1 MB; 4096 would be 2.2
    rays, reason = small_mesh.chunk_rays(550, 512 << 10)
    assert rays == low and "the floor" in reason
    assert small_mesh.chunk_rays(550, None)[0] == small_mesh.SMALL_CHUNK_DEFAULT


def test_a_small_mesh_takes_its_chunk_from_the_l2(monkeypatch):
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 1, 0], [0, 1, 0], [1, 0, 0]]], float)
    monkeypatch.setattr(machine, "this_machine", lambda: machine.Machine("x", 1, L2=64 << 10))
    monkeypatch.setattr(small_mesh, "this_machine", machine.this_machine)
    mesh = small_mesh.SmallMesh(tri)
    assert mesh.chunk == small_mesh.chunk_rays(mesh.scratch_bytes_per_ray(), 64 << 10)[0]
    # Rays in several chunks find what one chunk finds.
    rng = np.random.default_rng(3)
    o = np.column_stack((rng.uniform(0, 1, 5000), rng.uniform(0, 1, 5000), np.ones(5000)))
    d = np.tile([0.0, 0.0, -1.0], (5000, 1))
    t, prim, _, _ = mesh.intersect(o, d)
    assert np.all(prim >= 0) and np.allclose(t, 1.0)


def test_camera_images_do_not_depend_on_the_memory_a_machine_has(monkeypatch):
    """Each render has more paths than the floor, so the floor splits it where the cap does not."""
    from pathtracer.render import driver
    used = []
    plan = driver.plan_units
    monkeypatch.setattr(driver, "plan_units", lambda n, spp, batch: used.append(batch) or plan(n, spp, batch))
    cases = [(load_scene("cornell-box", width=48, height=48), "path", 4),
             (load_scene("media-box", width=48, height=48), "volpath", 2),
             (load_scene("cornell-box", width=96, height=96), "light", 1)]
    plenty = [render(scene, name, spp=spp, seed=3, processes=1) for scene, name, spp in cases]
    # A machine with 40 MB available: the floor (4k paths) instead of 32k.
    monkeypatch.setattr(resources, "available_memory", lambda: 40 << 20)
    assert sizes.machine_batch(1).paths == sizes.BATCH_FLOOR
    short = [render(scene, name, spp=spp, seed=3, processes=1) for scene, name, spp in cases]
    # The light tracer keeps its fixed batch on both machines.
    assert used == [sizes.BATCH_CAP] * 3 + [sizes.BATCH_FLOOR, sizes.BATCH_FLOOR, sizes.BATCH_CAP]
    for before, after in zip(plenty, short):
        assert np.array_equal(before.mean, after.mean)
        assert np.array_equal(before.variance, after.variance)


def test_render_verbose_says_the_machine_and_the_sizes(tmp_path, capsys):
    code = main(["render", "cornell-box", "-D", "width=8", "-D", "height=8", "--spp", "1",
                 "--processes", "1", "--verbose", "-o", str(tmp_path / "c.exr")])
    err = capsys.readouterr().err
    assert code == 0
    assert f"machine: {machine.this_machine().describe()}" in err
    assert f"batch: {sizes.machine_batch(1).paths} paths per process" in err
    assert "all-pairs chunk: " in err
    main(["render", "cornell-box", "-D", "width=8", "-D", "height=8", "--spp", "1",
          "--processes", "1", "-o", str(tmp_path / "quiet.exr")])
    assert "machine:" not in capsys.readouterr().err
