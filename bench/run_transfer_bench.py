#!/usr/bin/env python3
"""Data transfer (issue 17): build time with and without --transfer, and the
memory of the transferred arrays, per mesh, with hdt-voxelize on this machine.

Each mesh is rewritten (in a temporary folder, never the repository) as a
binary PLY with a vertex property t = x (a point array) and a face property
face = the face index (a cell array), so every format gets both kinds.
For each mesh and N: the plain build and the build with --transfer t
--transfer face, best of R runs; reported: build total (time_ms.total),
the transfer pass (io_ms.transfer), its ratio to the build, the arrays' bytes
(transferred_array_bytes) and the leaf bytes for scale.

  pvpython bench/run_transfer_bench.py --tool build/apps/hdt-voxelize \   (any python3 with numpy)
      --meshes ../shared/meshes --sizes 1024 --out bench/results/transfer.md
"""
import argparse
import datetime
import json
import os
import platform
import re
import struct
import subprocess
import tempfile

import numpy as np

PLY_TYPES = {"float": "<f4", "float32": "<f4", "double": "<f8", "float64": "<f8", "uchar": "u1", "uint8": "u1",
             "char": "i1", "int8": "i1", "ushort": "<u2", "uint16": "<u2", "short": "<i2", "int16": "<i2",
             "int": "<i4", "int32": "<i4", "uint": "<u4", "uint32": "<u4"}


def read_binary_ply(path):
    """Binary little-endian PLY with triangle faces only (the shared meshes)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode().splitlines()
    elements, current = [], None
    for line in header:
        w = line.split()
        if w[0] == "element":
            current = [w[1], int(w[2]), []]
            elements.append(current)
        elif w[0] == "property":
            current[2].append(w[1:])
    pos, pts, tris = end, None, None
    for name, count, props in elements:
        if name == "vertex":
            dt = np.dtype([(p[1], PLY_TYPES[p[0]]) for p in props])
            v = np.frombuffer(data, dt, count, pos)
            pos += dt.itemsize * count
            pts = np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64)
        elif name == "face":
            p = props[0]
            assert p[0] == "list" and all(q[0] != "list" for q in props[1:]), "faces: the index list first"
            nt, it = np.dtype(PLY_TYPES[p[1]]), np.dtype(PLY_TYPES[p[2]])
            rest = sum(np.dtype(PLY_TYPES[q[0]]).itemsize for q in props[1:])  # scalar face properties
            tris = []
            for _ in range(count):  # polygons as fans
                n = int(np.frombuffer(data, nt, 1, pos)[0])
                idx = np.frombuffer(data, it, n, pos + nt.itemsize)
                pos += nt.itemsize + n * it.itemsize + rest
                tris += [(idx[0], idx[k], idx[k + 1]) for k in range(1, n - 1)]
            tris = np.array(tris, np.int64)
    return pts, tris


def read_obj(path):
    pts, tris = [], []
    for line in open(path, errors="replace"):
        if line.startswith("v "):
            pts.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("f "):
            idx = [int(w.split("/")[0]) for w in line.split()[1:]]
            idx = [i - 1 if i > 0 else len(pts) + i for i in idx]
            for k in range(1, len(idx) - 1):
                tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(pts, np.float64), np.array(tris, np.int64)


def write_ply(path, pts, tris):
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
                 "property float z\nproperty float t\nelement face %d\nproperty list uchar int vertex_indices\n"
                 "property int face\nend_header\n" % (len(pts), len(tris))).encode())
        v = np.zeros(len(pts), np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("t", "<f4")]))
        v["x"], v["y"], v["z"], v["t"] = pts[:, 0], pts[:, 1], pts[:, 2], pts[:, 0]
        f.write(v.tobytes())
        t = np.zeros(len(tris), np.dtype([("n", "u1"), ("i", "<i4", 3), ("face", "<i4")]))
        t["n"], t["i"], t["face"] = 3, tris, np.arange(len(tris))
        f.write(t.tobytes())


def run(tool, mesh, n, extra):
    out = subprocess.run([tool, mesh, "--resolution", str(n), "--backend", "cpu", "--json", "--quiet"] + extra,
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tool", required=True)
    ap.add_argument("--meshes", required=True)
    ap.add_argument("--names", nargs="*", default=["stanford-dragon-100k.ply", "ogre.obj", "cycloidal-drive.ply"])
    ap.add_argument("--sizes", nargs="*", type=int, default=[1024])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.names:
            src = os.path.join(args.meshes, name)
            if not os.path.exists(src):
                continue
            pts, tris = read_obj(src) if name.endswith(".obj") else read_binary_ply(src)
            ply = os.path.join(tmp, os.path.splitext(name)[0] + "-props.ply")
            write_ply(ply, pts, tris)
            for n in args.sizes:
                plain = min((run(args.tool, ply, n, []) for _ in range(args.repeat)),
                            key=lambda d: d["time_ms"]["total"])
                moved = min((run(args.tool, ply, n, ["--transfer", "t", "--transfer", "face"])
                             for _ in range(args.repeat)), key=lambda d: d["io_ms"]["transfer"])
                assert moved["active_voxels"] == plain["active_voxels"]
                rows.append((name, n, len(tris), plain["active_voxels"], plain["threads"], plain["time_ms"]["total"],
                             moved["io_ms"]["transfer"], moved["io_ms"]["transfer"] / plain["time_ms"]["total"],
                             moved["transferred_array_bytes"], plain["leaf_bytes"]))
                print(rows[-1], flush=True)
    load = os.getloadavg()[0]
    with open(args.out, "w") as f:
        f.write("# Data transfer (issue 17): time and memory of the transferred arrays\n\n")
        f.write("Machine: %s, %d cores, load %.1f; %s. Command: `pvpython bench/run_transfer_bench.py --tool %s "
                "--sizes %s`. CPU driver, best of %d. Arrays: a point array (t = x) and a cell array (the face "
                "index), one float32 component each, on every surface voxel.\n\n"
                % (platform.node(), os.cpu_count(), load, datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
                   os.path.relpath(args.tool), " ".join(map(str, args.sizes)), args.repeat))
        f.write("| mesh | N | triangles | surface voxels | threads | build ms | transfer ms | transfer / build "
                "| array bytes | leaf bytes |\n")
        f.write("|---|---|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write("| %s | %d | %d | %d | %d | %.0f | %.0f | %.2f | %d | %d |\n" % r)


if __name__ == "__main__":
    main()
