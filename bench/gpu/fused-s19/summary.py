#!/usr/bin/env python3
"""Summary of bench/gpu/fused-s19/call.sh: per mesh and mode, the GPU phases'
total and the T3 (leaf) and classification times of every process, by
variant (the files' names: VARIANT-ROUND.jsonl), and whether the inside and
surface voxel counts agree across variants. With a second argument, also
writes every line there, tagged with its "binary" (variant) and "round"."""
import glob, json, os, statistics, sys
from collections import defaultdict

rows = defaultdict(lambda: defaultdict(list))  # (mesh, mode) -> variant -> [(total, leaf, classify)]
counts = defaultdict(set)
tagged = open(sys.argv[2], "w") if len(sys.argv) > 2 else None
for path in sorted(glob.glob(os.path.join(sys.argv[1], "*.jsonl"))):
    variant, round_ = os.path.basename(path)[: -len(".jsonl")].rsplit("-", 1)
    for line in open(path):
        d = json.loads(line)
        if tagged:
            tagged.write(json.dumps(dict(d, binary=variant, round=int(round_))) + "\n")
        t = d["time_ms"]
        key = (d["mesh"], d["resolution"], d["mode"])
        rows[key][variant].append((t["total"], t.get("leaf", 0.0), t.get("classify", 0.0)))
        counts[key].add((d.get("inside_voxels"), d.get("active_voxels")))
variants = sorted({v for r in rows.values() for v in r})
print("mesh res mode | " + " | ".join(f"{v}: total (T3, class) per process" for v in variants) + " | median change fused/twopass | counts equal")
for key in sorted(rows):
    cells, med = [], {}
    for v in variants:
        xs = rows[key].get(v, [])
        cells.append(" ".join(f"{a:.2f}({b:.2f},{c:.2f})" for a, b, c in xs))
        if xs:
            med[v] = statistics.median(a for a, _, _ in xs)
    change = ""
    if "fused" in med and "twopass" in med:
        change = f"{med['twopass']:.2f} -> {med['fused']:.2f} ({100 * (med['fused'] / med['twopass'] - 1):+.1f} %)"
    print(f"{key[0]} {key[1]} {key[2]} | " + " | ".join(cells) + f" | {change} | {'yes' if len(counts[key]) == 1 else 'NO'}")
