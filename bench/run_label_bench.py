#!/usr/bin/env python3
"""Labelled against unlabelled builds (issue 17): build time and label memory.

    python3 bench/run_label_bench.py --tool build/apps/hdt-voxelize \
        --meshes ../shared/meshes --backend cpu --sizes 256 512 --out bench/results/labels.md

For each mesh and N: the plain build and the build labelled by connected
components (--labels components), the best of --repeat runs of each, timed as
the caller waits (io_ms.build: the build call, the CUDA driver's copy back
included; labelled: every part and the combination), and the label field's
bytes against the leaf data's. The plain build's time_ms.total (for the CUDA
driver: its device phases only, no copy back) is listed beside it.
"""
import argparse, json, os, platform, re, subprocess, time

MESHES = ["cycloidal-drive.ply", "ogre.obj", "stanford-dragon-100k.ply"]


def run(tool, args):
    """The CLI's JSON, plus copy_back_mib: the device labelled build's copy
    back as its log line states it (None for other builds)."""
    out = subprocess.run([tool] + args + ["--json"], check=True, capture_output=True, text=True)
    d = json.loads(out.stdout)
    m = re.search(r"\((\d+) MiB in \d+ ms\)", out.stderr)
    d["copy_back_mib"] = int(m.group(1)) if m else None
    return d


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--tool", required=True)
    ap.add_argument("--meshes", required=True)
    ap.add_argument("--backend", default="cpu")
    ap.add_argument("--sizes", type=int, nargs="+", default=[256, 512])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", required=True)
    # Parity by default: the labelled path's device combination takes closed
    # parts and parity; Auto would send open meshes to the winding number.
    ap.add_argument("--inside-test", default="parity")
    a = ap.parse_args()
    rows = []
    for mesh in MESHES:
        path = os.path.join(a.meshes, mesh)
        if not os.path.exists(path):  # the GPU machine carries the meshes as binary PLY
            path = os.path.splitext(path)[0] + ".ply"
        if not os.path.exists(path):
            continue
        for n in a.sizes:
            base = [path, "--resolution", str(n), "--backend", a.backend, "--inside-test", a.inside_test]
            plain = min((run(a.tool, base) for _ in range(a.repeat)), key=lambda d: d["io_ms"]["build"])
            lab = min((run(a.tool, base + ["--labels", "components"]) for _ in range(a.repeat)),
                      key=lambda d: d["io_ms"]["build"])
            rows.append((mesh, n, len(lab["labels"]), plain["time_ms"]["total"], plain["io_ms"]["build"],
                         lab["io_ms"]["build"],
                         plain["leaf_bytes"], lab["label_bytes"], lab["active_voxels"] == plain["active_voxels"],
                         lab["backend"], lab["threads"], lab["copy_back_mib"], plain["peak_host_bytes"],
                         lab["peak_host_bytes"]))
            print(rows[-1], flush=True)
    with open(a.out, "w") as f:
        f.write("# Labelled builds (issue 17): time and label memory\n\n")
        f.write("Machine: %s, %d cores, load %s; %s. Command: `python3 bench/run_label_bench.py --tool %s "
                "--meshes ... --backend %s --sizes %s --inside-test %s`. Labels: connected components (`--labels components`). "
                "Times: best of %d, in ms, as the caller waits (`io_ms.build`: the build call with the copy back; "
                "labelled: every part and the combination); `plain phases`: the plain build's `time_ms.total`. "
                "Label bytes: `labelFieldBytes` (element labels, 2 B an element; mixed leaves: an 8 B palette, "
                "2 bits a voxel or, with 5 labels or more, 2 B a voxel; the index, 8 B a mixed leaf and 4 B a leaf). "
                "Copy back: the labelled device build's, from its log line (all of the volume). Peak host: "
                "`peak_host_bytes` (resident set), plain / labelled.\n\n"
                % (platform.node(), os.cpu_count(), os.getloadavg()[0], time.strftime("%Y-%m-%d %H:%M"), a.tool,
                   a.backend, " ".join(map(str, a.sizes)), a.inside_test, a.repeat))
        f.write("| mesh | N | labels | backend | plain phases ms | plain ms | labelled ms | ratio | leaf bytes | "
                "label bytes | label / leaf | copy back MiB | peak host GiB | same surface |\n"
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n")
        for m, n, k, phases, tp, tl, lb, lab, same, backend, threads, copy, hp, hl in rows:
            f.write("| %s | %d | %d | %s (%d threads) | %.0f | %.0f | %.0f | %.2f | %d | %d | %.2f | %s | %.2f / %.2f | %s |\n"
                    % (m, n, k, backend, threads, phases, tp, tl, tl / tp, lb, lab, lab / lb,
                       "-" if copy is None else str(copy), hp / 2**30, hl / 2**30, same))


if __name__ == "__main__":
    main()
