"""Smoke test of the benchmark script (not a timing assertion): --quick runs and gives sane numbers."""
import json
import math

from experiments import bench


def test_quick_bench_produces_sane_numbers(tmp_path, capsys):
    out = tmp_path / "bench.json"
    # Mitsuba is exercised by the full benchmark; the smoke test stays fast and self-contained.
    assert bench.main(["--quick", "--no-mitsuba", "--no-scaling", "--resolution", "16",
                       "--spp", "2", "--memory", "64", "1", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert set(report["scenes"]) == {"cornell-box", "smallpt", "mesh"}
    for label, row in report["scenes"].items():
        assert "error" not in row["ours"], (label, row["ours"])
        rate = row["rate"]["ours"]
        assert rate is not None and math.isfinite(rate) and 1e2 < rate < 1e9, (label, rate)
        assert row["ours"]["paths"] == row["width"] * row["height"] * report["spp"]
        assert row["rate"]["scalar_rgb"] is None and row["target_met"] is None  # no Mitsuba run
    for label, row in report["batch"].items():
        assert "error" not in row["ours"], (label, row["ours"])
        assert row["ours"]["sizes"][0].startswith("batch: "), (label, row["ours"]["sizes"])
    assert "Sizes chosen from the machine" in capsys.readouterr().out
    memory = report["memory"]
    assert "error" not in memory, memory
    assert 10 < memory["rss_mb"] < 4000
    # Summed PSS never exceeds the summed peak RSS (it counts shared pages once).
    assert 10 < memory["peak_mb"] <= memory["rss_sum_mb"] and memory["pss_processes"] >= 1
    table = bench.table(report)
    assert "| cornell-box" in table and "Peak memory" in table
    assert "| volpath (media-box, 16x16)" in table and "| pathclass (cornell-box" in table


def test_profile_splits_a_render_into_stages(capsys):
    """experiments.profile: stage shares are fractions that add up to the render, and they see
    the estimator: smallpt traces no shadow rays, the MIS path tracer spends on both ray kinds."""
    from experiments import profile
    path = profile.profile_scene("cornell-box", "path", 16, 16, 2)
    smallpt = profile.profile_scene("smallpt", "smallpt", 16, 12, 2)
    for found in (path, smallpt):
        stages = [s for s, _, _ in profile.STAGES] + ["everything else"]
        assert all(found[s] >= -1e-9 for s in stages)
        assert abs(sum(found[s] for s in stages) - found["total"]) < 1e-9
    assert path["shadow rays (geometry.occluded)"] > 0 and path["closest hits (geometry.intersect)"] > 0
    assert smallpt["shadow rays (geometry.occluded)"] == 0
    assert profile.main(["--scenes", "cornell-box", "--resolution", "8", "--spp", "1"]) == 0
    assert "| closest hits" in capsys.readouterr().out


def test_machine_probe_reports_every_figure_with_its_cpu(tmp_path, capsys):
    """experiments.machine_probe: one positive, finite figure per kind of work, the CPU named."""
    from experiments import machine_probe
    out = tmp_path / "probe.json"
    assert machine_probe.main(["--repeats", "1", "--json", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["cpu"] and report["numpy"] and len(report["ns"]) == 6
    assert all(math.isfinite(ns) and ns > 0 for ns in report["ns"].values()), report["ns"]
    assert report["cpu"] in capsys.readouterr().out
