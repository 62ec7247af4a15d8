#!/usr/bin/env python3
"""Strong scaling of hdt-voxelize-mpi over CPU ranks (issue 14).

For each mesh and resolution, each configuration in its own process under
mpiexec (Open MPI), median of --reps runs:
  serial   hdt-voxelize, all cores (the reference)
  1x1      1 rank, 1 thread          2x1  2 ranks, 1 thread each (one core each)
  1x2      1 rank, 2 threads         2x2  2 ranks, 2 threads each (oversubscribed)
Every MPI result is checked against the serial .hdt (tests/cli/compare_hdt.py).
Appends one JSON line per run to bench/results/mpi-cpu-runs.jsonl (the tool's
JSON + config, ranks, threads_per_rank, wall_s, machine, date, loadavg_1m) and
prints a table of medians.

  bench/mpi_scaling.py --build build --mesh ../shared/meshes/stanford-dragon-100k.ply --res 1024 2048
"""
import argparse
import datetime
import json
import os
import platform
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CONFIGS = [("serial", 1, 0), ("1x1", 1, 1), ("2x1", 2, 1), ("1x2", 1, 2), ("2x2", 2, 2)]


def run(cmd):
    t0 = time.perf_counter()
    out = subprocess.run(cmd, check=True, capture_output=True, text=True, env=ENV).stdout
    return json.loads(out), time.perf_counter() - t0


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--build", default=os.path.join(ROOT, "build"))
    p.add_argument("--mesh", nargs="+", required=True)
    p.add_argument("--res", nargs="+", type=int, default=[1024, 2048])
    p.add_argument("--reps", type=int, default=3)
    p.add_argument("--out", default=os.path.join(HERE, "results", "mpi-cpu-runs.jsonl"))
    a = p.parse_args()
    serial = os.path.join(a.build, "apps", "hdt-voxelize")
    mpi = os.path.join(a.build, "apps", "hdt-voxelize-mpi")
    tmp = "/tmp/hdt-mpi-bench"
    os.makedirs(tmp, exist_ok=True)
    date = datetime.datetime.now().isoformat(timespec="minutes")
    machine = "%s, %d cores" % (platform.node(), os.cpu_count())
    rows = []
    with open(a.out, "a") as log:
        for mesh in a.mesh:
            for n in a.res:
                ref = os.path.join(tmp, "serial.hdt")
                for name, ranks, threads in CONFIGS:
                    walls, builds = [], []
                    for rep in range(a.reps):
                        out = os.path.join(tmp, name + ".hdt")
                        args = [mesh, "--resolution", str(n), "--backend", "cpu", "--json", "--quiet", "-o",
                                ref if name == "serial" else out]
                        if name == "serial":
                            cmd = [serial] + args
                        else:
                            # One core per rank when the threads fit, else no binding.
                            bind = ["--bind-to", "core"] if ranks * threads <= os.cpu_count() else ["--bind-to", "none"]
                            cmd = ["mpiexec", "--oversubscribe"] + bind + ["-n", str(ranks), mpi] + args + [
                                "--threads", str(threads)]
                        res, wall = run(cmd)
                        if name != "serial":
                            subprocess.run([sys.executable, os.path.join(ROOT, "tests", "cli", "compare_hdt.py"),
                                            ref, out], check=True, capture_output=True)
                        res.update(config=name, rank_count=ranks, threads_per_rank=threads, rep=rep, wall_s=wall,
                                   machine=machine, date=date, loadavg_1m=os.getloadavg()[0])
                        log.write(json.dumps(res) + "\n")
                        log.flush()
                        walls.append(wall)
                        builds.append(res["time_ms"]["total"])
                    rows.append((os.path.basename(mesh), n, name, statistics.median(builds),
                                 statistics.median(walls), res["peak_host_bytes"] / 2**20))
                    print("%s %d %s build %.0f ms, wall %.2f s" % rows[-1][:5], flush=True)
    print("\n| mesh | N | config | build ms (median) | wall s (median) | peak MiB (rank 0) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print("| %s | %d | %s | %.0f | %.2f | %.0f |" % r)


ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")

if __name__ == "__main__":
    main()
