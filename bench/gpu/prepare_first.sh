#!/usr/bin/env bash
# prepareMesh's first call in fresh processes, two or more binaries of bench/gpu/prepare_first.cpp
# alternating run by run (one process a run; the first call and the best of 8 more), e.g. main's
# and a branch's, each linked to its tree's libhdt_core.a on the development machine:
#   g++ -O3 -DNDEBUG -std=c++17 -Icore/include -Ibench/gpu -I.devdeps/include bench/gpu/prepare_first.cpp \
#     build-device/core/libhdt_core.a -L.devdeps/lib/x86_64-linux-gnu -ltbb -lzstd -lz -lpthread -o DIR/pf-new
#   OUT=DIR bench/gpu/prepare_first.sh DIR/pf-base DIR/pf-new      (from the repository root)
# Meshes from .devdeps/meshes (PREPARE_FIRST_MESHES: "MESH:SUBDIVIDE[:TRIANGLES] ...": TRIANGLES cuts
# the subdivided mesh to its first TRIANGLES triangles), ROUNDS rounds. A binary given as BIN:MODE runs
# in that prepare_first mode (warm, sleep, wake, cold; default warm), e.g. DIR/pf-new:sleep.
# Lines to $OUT/prepare-first-ab.jsonl, a summary (ranges, medians, steps) on stdout.
set -u
D=$(pwd)/.devdeps
export LD_LIBRARY_PATH=$D/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}
echo "nproc $(nproc) $(date -u +%FT%TZ) $(uname -r) $(grep -m1 "model name" /proc/cpuinfo | cut -d: -f2)"
for spec in ${PREPARE_FIRST_MESHES:-stanford-dragon-100k:1 nefertiti:1}; do
  for r in $(seq 1 "${ROUNDS:-10}"); do
    for v in "$@"; do
      b=${v%%:*} mode=warm
      [[ $v == *:* ]] && mode=${v#*:}
      echo -n "{\"round\": $r, \"variant\": \"$(basename "$v")\", \"run\": "
      IFS=: read -r mesh k cut <<<"$spec"
      "$b" "$D/meshes/$mesh.ply" "$k" 8 "$mode" ${cut:-} | tr -d '\n'
      echo "}"
    done
  done
done >"$OUT/prepare-first-ab.jsonl"
python3 - "$OUT/prepare-first-ab.jsonl" <<'PY'
import collections, json, sys
rows = collections.defaultdict(list)
for line in open(sys.argv[1]):
    d = json.loads(line); r = d["run"]
    rows[(r["mesh"].split("/")[-1], r["triangles"], d["variant"])].append(r)
for key, rs in rows.items():
    first = sorted(x["first_ms"] for x in rs); best = sorted(x["best_ms"] for x in rs)
    print(*key, "first", [round(x, 2) for x in first], "median", round(first[len(first) // 2], 2),
          "| best", [round(x, 2) for x in best])
    for i, name in enumerate(["bounds", "numbers", "closed"]):
        f = [x["first_steps"][i] for x in rs]; b = [x["best_steps"][i] for x in rs]
        print(f"    {name}: first {min(f):.2f}-{max(f):.2f}, best {min(b):.2f}-{max(b):.2f}")
    print("    first call's minor faults", min(x["first_minflt"] for x in rs), "-", max(x["first_minflt"] for x in rs))
PY
