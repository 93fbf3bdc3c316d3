"""Measure a reference built serially and through a Dask cluster (docs/cluster.md).

``python -m experiments.cluster_build --dask tcp://127.0.0.1:8786 [--scene cornell-box]
[--integrator path] [--spp 4096] [--resolution 64x64] [--tasks N]``

Renders the reference in this process (serial), then through the cluster's workers
(:class:`mitsuba_refs.cluster.site.ClusterSite`), checks that the two are identical bit for
bit, and prints one JSON line: both wall times, the speedup, the tasks' compute seconds
(Dask's task stream), the overhead per task (their sum less the serial render, per task) and
the scheduler's round trip of an empty task.
"""
import argparse
import json
import time

import numpy as np
from distributed import get_task_stream

from mitsuba_refs.cluster.client import connect, worker_count
from mitsuba_refs.cluster.site import ClusterSite
from mitsuba_refs.reference.calls import render_calls
from mitsuba_refs.reference.render import render_reference, resolve_scene
from mitsuba_refs.reference.split import ReferenceJob, calls_split_by, chunks
from pathtracer.scene.load import parse_resolution


def _noop(value):
    return value


def _timed_calls(job, run):
    """:func:`render_calls` and the CPU seconds the task took (contention-proof, unlike wall)."""
    start = time.process_time()
    blocks = render_calls(job, run)
    return blocks, time.process_time() - start


def _timed_split(client, job, tasks, cpu):
    """A split like :class:`ClusterSite`'s whose tasks also report their CPU seconds."""
    def split(calls):
        futures = [client.submit(_timed_calls, job, run, pure=False) for run in chunks(calls, tasks)]
        for future in futures:
            blocks, seconds = future.result()
            cpu.append(seconds)
            yield from blocks
    return split


def main(argv=None) -> int:
    """Measure; print one JSON line."""
    p = argparse.ArgumentParser(prog="python -m experiments.cluster_build")
    p.add_argument("--dask", required=True, metavar="ADDRESS")
    p.add_argument("--scene", default="cornell-box")
    p.add_argument("--integrator", default="path")
    p.add_argument("--spp", type=int, default=4096)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--resolution", type=parse_resolution, default=(64, 64))
    p.add_argument("--tasks", type=int, default=None)
    args = p.parse_args(argv)
    common = dict(variant="scalar_rgb", resolution=args.resolution)
    job = ReferenceJob(str(resolve_scene(args.scene)), {}, args.integrator, args.spp, args.seed,
                       "scalar_rgb", None, tuple(args.resolution))
    start, cpu_start = time.perf_counter(), time.process_time()
    serial = render_reference(args.scene, {}, args.integrator, args.spp, args.seed, **common)
    serial_s, serial_cpu = time.perf_counter() - start, time.process_time() - cpu_start
    with connect(args.dask) as client:
        client.wait_for_workers(1, timeout=60)
        start = time.perf_counter()
        client.gather([client.submit(_noop, i, pure=False) for i in range(200)])
        round_trip = (time.perf_counter() - start) / 200
        site = ClusterSite(client, args.dask, tasks=args.tasks)
        with get_task_stream(client) as stream:
            start = time.perf_counter()
            with calls_split_by(site.split_for(job)):
                ref = render_reference(args.scene, {}, args.integrator, args.spp, args.seed,
                                       **common)
            cluster_s = time.perf_counter() - start
        workers = worker_count(client)
        cpu = []
        with calls_split_by(_timed_split(client, job, len(stream.data), cpu)):
            timed = render_reference(args.scene, {}, args.integrator, args.spp, args.seed,
                                     **common)
    computes = [sum(s["stop"] - s["start"] for s in task["startstops"] if s["action"] == "compute")
                for task in stream.data]
    print(json.dumps({
        "scene": args.scene, "integrator": args.integrator, "spp": args.spp,
        "resolution": list(args.resolution), "calls": ref.metadata["pass_seeds"].__len__(),
        "workers": workers, "tasks": len(computes),
        "serial_s": round(serial_s, 2), "cluster_s": round(cluster_s, 2),
        "speedup": round(serial_s / cluster_s, 2),
        "task_compute_s": round(sum(computes), 2),
        "overhead_per_task_s": round((sum(computes) - serial_s) / max(1, len(computes)), 3),
        "serial_cpu_s": round(serial_cpu, 2), "task_cpu_s": round(sum(cpu), 2),
        "cpu_overhead_per_task_s": round((sum(cpu) - serial_cpu) / max(1, len(cpu)), 3),
        "empty_task_round_trip_ms": round(1000 * round_trip, 2),
        "identical": all(np.array_equal(serial.mean, r.mean) and np.array_equal(serial.var, r.var)
                         for r in (ref, timed)),
    }))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
