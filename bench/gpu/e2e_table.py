#!/usr/bin/env python3
"""Markdown table of hdt_e2e_bench runs (JSON lines), in the order given:
python3 bench/gpu/e2e_table.py RUNS.jsonl..."""
import json
import sys

HEAD = ("| mesh | triangles | N | mode | leaf GB | read | prepare | warm-up wait | phases | build | "
        "copy back (GB/s) | write | file MB | wall | peak host GiB | peak device GiB | chunks |")


def row(r):
    mode = "surface" if r["surface_only"] else "solid"
    if r.get("streamed_write") is False:  # --no-stream: the writer compresses after the build
        mode += ", no stream"
    if "error" in r:
        return f"| {r['mesh']} | | {r['resolution']} | {mode} | error: {r['error'][:80]} |" + " |" * 12
    copy = f"{r['copy_back_ms']:.1f} ({r['copy_back_gb_per_s']:.1f})" if r["copy_back_bytes"] else "-"
    return (f"| {r['mesh'].replace('.ply', '')} | {r['triangles']} | {r['resolution']} | {mode} | "
            f"{r['leaf_bytes'] / 1e9:.2f} | {r['read_ms']:.1f} | {r['prepare_ms']:.1f} | {r['warm_up_wait_ms']:.0f} | "
            f"{r['build_phases_ms']:.2f} | {r['build_wall_ms']:.1f} | {copy} | {r['write_ms']:.1f} | "
            f"{r['file_bytes'] / 1e6:.1f} | {r['wall_ms']:.0f} | {r['peak_host_bytes'] / 2**30:.2f} | "
            f"{r['peak_device_bytes'] / 2**30:.2f} | {r['chunks']} |")


print(HEAD)
print("|" + "---|" * (HEAD.count("|") - 1))
for f in sys.argv[1:]:
    for line in open(f):
        print(row(json.loads(line)))
