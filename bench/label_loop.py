#!/usr/bin/env python3
"""(bench/label_loop.py, used for bench/results/labels-gpu.md 2026-11-24 21:30)
Plain and labelled (components) hdt-voxelize builds alternating, N rounds per mesh;
one JSON line per run (io_ms, the log lines of stderr) to --out; best and median printed."""
import argparse, json, statistics, subprocess, sys, time
ap = argparse.ArgumentParser()
ap.add_argument("--tool", required=True)
ap.add_argument("--meshes", nargs="+", required=True)
ap.add_argument("--res", type=int, default=8192)
ap.add_argument("--rounds", type=int, default=3)
ap.add_argument("--out", required=True)
ap.add_argument("--tag", default="")
a = ap.parse_args()
with open(a.out, "a") as out:
    for mesh in a.meshes:
        t = {"plain": [], "labelled": []}
        for r in range(a.rounds):
            for kind in ("plain", "labelled"):
                args = [a.tool, mesh, "--resolution", str(a.res), "--backend", "cuda", "--inside-test", "parity", "--json"]
                if kind == "labelled":
                    args += ["--labels", "components"]
                p = subprocess.run(args, capture_output=True, text=True)
                if p.returncode != 0:
                    print("FAILED", mesh, kind, p.returncode, p.stderr[-2000:], flush=True)
                    continue
                d = json.loads(p.stdout)
                row = {"tag": a.tag, "utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()), "mesh": mesh.split("/")[-1],
                       "res": a.res, "kind": kind, "round": r, "io_ms": d.get("io_ms"), "active_voxels": d.get("active_voxels"),
                       "inside_voxels": d.get("inside_voxels"), "labels": len(d.get("labels", []) or []),
                       "label_bytes": d.get("label_bytes"), "peak_host_bytes": d.get("peak_host_bytes"),
                       "log": [l for l in p.stderr.splitlines() if "labelled" in l or "CUDA" in l]}
                out.write(json.dumps(row) + "\n")
                out.flush()
                t[kind].append(d["io_ms"]["build"])
                if kind == "labelled":
                    print(mesh.split("/")[-1], r, "plain %.0f labelled %.0f" % (t["plain"][-1], t["labelled"][-1]), row["log"], flush=True)
        if t["plain"] and t["labelled"]:
            bp, bl = min(t["plain"]), min(t["labelled"])
            mp, ml = statistics.median(t["plain"]), statistics.median(t["labelled"])
            print("SUMMARY %s %d: plain %s labelled %s best %.0f/%.0f=%.2f median %.0f/%.0f=%.2f" % (
                mesh.split("/")[-1], a.res, [round(x) for x in t["plain"]], [round(x) for x in t["labelled"]],
                bl, bp, bl / bp, ml, mp, ml / mp), flush=True)
