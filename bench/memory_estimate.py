#!/usr/bin/env python3
"""The host memory estimate (hdt::estimateHostBytes) against measured peaks.

Runs hdt-voxelize --backend cpu --json -o OUT.hdt over a grid of (mesh, N, R, L),
takes the child's peak resident set from wait4 (build and .hdt write both
included) and prints a markdown table of estimate / measured.

  python3 bench/memory_estimate.py BUILD/apps/hdt-voxelize [--meshes DIR] > table.md
"""
import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time

GRID = [  # (mesh, N, R, L): root-grid dominated, surface dominated, in between
    ("builtin:sphere", 1024, 16, 16),
    ("builtin:sphere", 2048, 16, 16),
    ("builtin:sphere", 2048, 256, 8),
    ("builtin:sphere", 2048, 128, 16),
    ("builtin:knot", 2048, 32, 8),
    ("builtin:knot", 4096, 512, 8),
    ("cycloidal-drive.ply", 2048, 16, 16),
    ("cycloidal-drive.ply", 4096, 16, 16),
    ("cycloidal-drive.ply", 8192, 16, 16),
    ("stanford-dragon-100k.ply", 4096, 32, 8),
    ("nefertiti.obj", 2048, 64, 32),
    ("turbine-blade.stl", 4096, 16, 32),
]


def run(tool, mesh, n, r, l, out):
    cmd = [tool, mesh, "--backend", "cpu", "--resolution", str(n), "--root-grid", str(r),
           "--leaf-size", str(l), "--json", "--quiet", "-o", out]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    stdout = proc.stdout.read()
    proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    if status != 0:
        return None
    doc = json.loads(stdout)
    return doc, usage.ru_maxrss * 1024


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("tool")
    ap.add_argument("--meshes", default="/work/shared/meshes")
    args = ap.parse_args()
    print(f"machine: {platform.node()} ({os.cpu_count()} cores), date: {time.strftime('%Y-%m-%d %H:%M %Z')}\n")
    print("| mesh | N | R | L | leaf grids | estimate MiB | measured peak MiB | estimate / measured |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for mesh, n, r, l in GRID:
            path = mesh if mesh.startswith("builtin:") else os.path.join(args.meshes, mesh)
            if not mesh.startswith("builtin:") and not os.path.exists(path):
                continue
            result = run(args.tool, path, n, r, l, os.path.join(tmp, "out.hdt"))
            if result is None:
                print(f"| {mesh} | {n} | {r} | {l} | failed | | | |")
                continue
            doc, peak = result
            est = doc["host_bytes_estimate"]
            print(f"| {mesh} | {n} | {r} | {l} | {doc['leaf_grids']} | {est >> 20} | {peak >> 20} | "
                  f"{est / peak:.2f} |", flush=True)


if __name__ == "__main__":
    sys.exit(main())
