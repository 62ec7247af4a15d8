#!/usr/bin/env bash
# A/B of several hdt_gpu_bench binaries in one device call: for every mesh,
# each binary runs in turn, ROUNDS times (one process a run of RUNS builds),
# so that clock and machine drift fall on all of them alike. Writes
# OUT/ab-NAME.jsonl per binary (NAME = the binary's file name) and prints a
# table of the median total and phases per mesh and mode.
#
#   ab_bench.sh OUT MESHDIR "MESH..." RES MODES RUNS ROUNDS BIN...
set -u -o pipefail
out=$1 meshdir=$2 meshes=$3 res=$4 modes=$5 runs=$6 rounds=$7
shift 7
mkdir -p "$out"
for m in $meshes; do
  for r in $(seq "$rounds"); do
    for b in "$@"; do
      timeout 120 "$b" --meshes "$meshdir" --mesh "$m" --res "$res" --modes "$modes" --runs "$runs" \
        --out "$out/ab-$(basename "$b").jsonl" >> "$out/ab.log" 2>&1 || echo "ab: rc=$? for $b $m" | tee -a "$out/ab.log"
    done
  done
done
python3 - "$out" "$@" <<'PY'
import json, sys, os, statistics, collections
out, bins = sys.argv[1], [os.path.basename(b) for b in sys.argv[2:]]
rows = collections.defaultdict(dict)
for b in bins:
    runs = collections.defaultdict(list)
    for l in open(os.path.join(out, f"ab-{b}.jsonl")):
        r = json.loads(l)
        runs[(r["mesh"], "surface" if r["surface_only"] else "solid")].append(r["time_ms"])
    for k, v in runs.items():
        rows[k][b] = {p: statistics.median(x[p] for x in v) for p in v[0]}
print("mesh mode: total ms per binary (" + " / ".join(bins) + "), then T1 T2 T3 classify of each")
for (m, mode), per in sorted(rows.items()):
    tot = " / ".join(f"{per[b]['total']:.3f}" if b in per else "-" for b in bins)
    ph = " | ".join(" ".join(f"{per[b][p]:.3f}" for p in ("mapping", "branching", "leaf", "classify")) for b in bins if b in per)
    print(f"{m[:22]:22} {mode:7} {tot}   [{ph}]")
PY
