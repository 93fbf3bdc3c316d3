"""The experiment scripts run on tiny settings and write their figures and numbers;
sweeps resume after an interruption and run on a Dask cluster."""
import json

import numpy as np
import pytest

from experiments import (
    bdpt_strategies,
    caustics,
    common,
    convergence,
    estimators,
    integrators,
    pathclasses,
    progression,
    samplers,
    sweep,
)


@pytest.mark.parametrize("module", [convergence, progression, estimators, pathclasses, sweep,
                                    bdpt_strategies, caustics, integrators, samplers],
                         ids=["error-vs-spp", "progression", "estimators", "pathclasses", "sweep",
                              "bdpt-strategies", "caustics", "integrators", "samplers"])
def test_help(module, capsys):
    with pytest.raises(SystemExit) as stop:
        module.main(["--help"])
    assert stop.value.code == 0
    assert "--out" in capsys.readouterr().out


def _outputs(folder, *names):
    for name in names:
        assert (folder / name).is_file() and (folder / name).stat().st_size > 0, name


def test_error_vs_spp_script(tmp_path, capsys):
    out = tmp_path / "conv"
    assert convergence.main(["--out", str(out), "--integrators", "path", "path_bsdf", "--spp", "1", "2", "4",
                             "--replicas", "2", "--workers", "1", "--no-progress"]) == 0
    _outputs(out, "convergence.png", "convergence.svg", "convergence.csv", "summary.csv", "summary.json",
             "results.jsonl")
    summary = json.loads((out / "summary.json").read_text())
    assert [r["integrator"] for r in summary["rows"]] == ["path", "path_bsdf"]
    assert all(-1.6 < r["mse_slope"] < -0.5 for r in summary["rows"])
    assert "RMSE(N)/RMSE(4N)" in capsys.readouterr().out


def test_convergence_figure_warns_when_rare_paths_carry_the_lowest_level():
    assert convergence.rare_path_caution([1.0, 1.2, 0.9, 1.1]) is None
    effective = convergence.rare_path_caution([40.0, 0.1, 0.1, 0.1])
    assert effective is not None and 1.0 <= effective < 1.1


def test_progression_without_mitsuba(tmp_path):
    out = tmp_path / "prog"
    assert progression.main(["--out", str(out), "--size", "16", "16", "--spp", "1", "4", "--no-mitsuba",
                             "--workers", "1", "--no-progress"]) == 0
    _outputs(out, "progression.png", "progression.svg", "progression.csv", "progression.npz")
    images = np.load(out / "progression.npz")
    assert images["ours_4"].shape == (16, 16, 3)


def test_progression_lecture_media(tmp_path):
    """The four media steps at 1 spp: the figure, and an RMSE per panel against the
    committed references."""
    import csv
    out = tmp_path / "media"
    assert progression.main(["--lecture-media", "--out", str(out), "--spp", "1",
                             "--workers", "1", "--no-progress"]) == 0
    _outputs(out, "lecture-media.png", "lecture-media.svg", "lecture-media.csv")
    rows = list(csv.DictReader(open(out / "lecture-media.csv")))
    assert len(rows) == 8 and all(float(r["rmse"]) > 0 for r in rows)


def test_progressive_mean_is_the_weighted_mean():
    images, _ = progression.progressive(lambda add, j: np.full((1, 1, 3), float(j)), [1, 4, 16],
                                        common.progress_bar(3, "t", False))
    assert np.allclose(images[-1], (0 * 1 + 1 * 3 + 2 * 12) / 16)


def test_estimators(tmp_path):
    out = tmp_path / "est"
    assert estimators.main(["--out", str(out), "--mis-size", "32", "24", "--mis-spp", "4", "--spp", "2",
                            "--budget", "0.3", "--branches", "2", "--depths", "1", "2",
                            "--workers", "1", "--no-progress"]) == 0
    for part in estimators.PARTS:
        _outputs(out, f"estimators-{part}.png", f"estimators-{part}.svg")
    rows = json.loads((out / "estimators.json").read_text())["rows"]
    assert {r["part"] for r in rows} == set(estimators.PARTS)
    recursive = [r for r in rows if r["part"] == "recursive"]
    assert recursive[2]["us_per_camera_sample"] > recursive[0]["us_per_camera_sample"]


def test_pathclasses(tmp_path):
    out = tmp_path / "pc"
    assert pathclasses.main(["--out", str(out), "--size", "16", "16", "--spp", "4", "--workers", "1",
                             "--no-progress"]) == 0
    _outputs(out, "pathclasses.png", "pathclasses.svg", "pathclasses-bounces.png", "pathclasses.csv")
    data = json.loads((out / "pathclasses.json").read_text())
    assert data["partition_max_abs_error"] < 1e-10
    assert len(data["bounces"]) == 3


def _tasks():
    return sweep.make_tasks(["cornell-box"], ["path_bsdf"], [1, 2], 2, 123)


def test_sweep_writes_incrementally_and_resumes(tmp_path, monkeypatch):
    out = tmp_path / "sweep"
    assert sweep.main(["--out", str(out), "--scenes", "cornell-box", "--integrators", "path_bsdf",
                       "--spp", "1", "2", "--seeds", "2", "--seed", "123", "--workers", "1",
                       "--no-progress"]) == 0
    _outputs(out, "sweep.png", "sweep.svg", "sweep.csv", "summary.csv")
    lines = (out / "results.jsonl").read_text().splitlines()
    assert len(lines) == 4 and all(json.loads(l)["rmse"] > 0 for l in lines)
    # an interrupted sweep: the last record lost, the one before torn mid-write
    (out / "results.jsonl").write_text("\n".join(lines[:2]) + "\n" + lines[2][:25])
    calls = []
    real = common.run_task
    monkeypatch.setattr(common, "run_task", lambda task: calls.append(task) or real(task))
    store = sweep.run_sweep(_tasks(), out, workers=1, progress=False)
    assert len(calls) == 2 and len(store) == 4
    calls.clear()
    sweep.run_sweep(_tasks(), out, workers=1, progress=False)
    assert calls == []


def test_sweep_on_a_process_pool(tmp_path):
    store = sweep.run_sweep(_tasks(), tmp_path, workers=2, progress=False)
    inline = sweep.run_sweep(_tasks(), tmp_path / "inline", workers=1, progress=False)
    for task in _tasks():   # the same seed gives the same image wherever it runs
        assert store.get(task)["image_mean"] == inline.get(task)["image_mean"]


def test_sweep_on_a_dask_local_cluster(tmp_path):
    distributed = pytest.importorskip("distributed", reason="dask.distributed not installed "
                                      "(pip install -e '.[dask]')")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster:
        store = sweep.run_sweep(_tasks(), tmp_path, dask=cluster.scheduler_address, progress=False)
    assert len(store) == 4
    reference = sweep.run_sweep(_tasks()[:1], tmp_path / "inline", workers=1, progress=False)
    task = _tasks()[0]
    assert store.get(task)["image_mean"] == reference.get(task)["image_mean"]


def test_bdpt_strategies_script(tmp_path, capsys):
    out = tmp_path / "bdpt"
    assert bdpt_strategies.main(["--out", str(out), "--longest", "2", "--spp", "2", "-D", "width=8",
                                 "-D", "height=8", "--no-progress"]) == 0
    _outputs(out, "bdpt-strategies.png", "bdpt-weighted.png", "bdpt-strategies.csv")
    assert "k=2 (s=2, t=1)" in capsys.readouterr().out


@pytest.mark.statistical(assertions=1)
def test_caustics_script(tmp_path, capsys):
    """A fraction of a CPU second per integrator on the point light: the figures and the
    numbers are written, and the harness says that path tracing with shadow rays misses the
    caustic (a disagreement whose worst tile is at the caustic), not that it passes."""
    out = tmp_path / "caustics"
    assert caustics.main(["--out", str(out), "--lights", "point", "--seconds", "0.15",
                          "--no-progress"]) == 0
    _outputs(out, "caustics.png", "caustics-error.png", "caustics.json")
    numbers = json.loads((out / "caustics.json").read_text())["lights"]["point"]
    rows = numbers["integrators"]
    assert list(rows) == ["path_bsdf", "path", "light", "bdpt"]
    for row in rows.values():
        assert len(row["curve"]) >= 2 and row["spp"] >= 2
        assert all(np.isfinite([p["seconds"], p["rmse"]]).all() for p in row["curve"])
    assert numbers["caustic_pixels"] > 0
    path = rows["path"]
    assert not path["agree"] and path["worst_in_caustic"], path["verdict"]
    assert "path on the point light" in capsys.readouterr().out


def test_integrators_script(tmp_path, capsys):
    """The four-integrator table on one small scene with a directional light: recursive and
    path get numbers (path's relative efficiency is 1), light and bdpt say why they cannot run."""
    out = tmp_path / "integrators"
    assert integrators.main(["--out", str(out), "--scenes", "spot-directional", "--seconds", "0.1",
                             "--no-progress"]) == 0
    rows = json.loads((out / "integrators.json").read_text())["scenes"]["spot-directional"]["integrators"]
    assert rows["path"]["efficiency_relative"] == 1.0 and rows["recursive"]["rmse"] > 0
    assert rows["path"]["spp"] >= 2 and rows["path"]["agree"] in (True, False)
    for name in ("light", "bdpt"):
        assert not rows[name]["ran"] and "directional" in rows[name]["reason"]
    table = capsys.readouterr().out
    assert "| `spot-directional` (32×32) |" in table and "cannot run" in table


def test_bench_accel_replays_a_renders_queries(capsys):
    """``bench_accel --render-queries`` records the mesh scene's BVH queries during a render
    and replays them (the 'replay' of docs/performance.md)."""
    from experiments import bench_accel
    bench_accel.render_queries(size=16, spp=1, repeat=1)
    out = capsys.readouterr().out
    calls = int(out.split(": ")[1].split(" calls")[0])
    assert calls > 0 and "rays/s" in out
