#!/bin/bash
# Session 20 (prepared; not run: no device machine was lent in that session).
# The device checks of main and the box kernels' register limit at
# other block counts. Binaries in .devcarry/s20.tar.xz (untracked), built as in
# gpu-notes.md (build-devbin: Release, 90-real, no ParaView, no assimp), stripped:
#   s20/main/hdt_gpu_bench            main ee5c8b3 (kBoxBlocksPerSM 12)
#   s20/s20/{hdt_cuda_tests,hdt_gpu_bench}   branch s20-launch: leafBoxesKernel's
#                                     instance picked through a kernel pointer
#   s20/b14, s20/b16/hdt_gpu_bench   s20-launch with kBoxBlocksPerSM 14 / 16
#                                     (at most 72 / 64 registers a thread)
# Every device test of s20 beside memcheck on the winding tests; then the
# bench processes alternating, HDT_WINDING_TRACE on (steps.py reads the steps).
. bench/gpu/call-setup.sh s20
B=/tmp/s20
deviceTests $B/s20/hdt_cuda_tests '*Winding*' 120 200
W=/tmp/s20w; rm -rf $W; mkdir -p $W
bench() { # variant round
  HDT_WINDING_TRACE=1 timeout 60 $B/$1/hdt_gpu_bench --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply \
    --mesh cycloidal-drive.ply --res 8192 --root 8 --modes solid,winding --runs 3 --out $W/$1-$2.jsonl > $W/$1-$2.log 2>&1
  echo "bench $1 round $2 rc=$? at $((SECONDS-T0)) s"
}
for r in 1 2 3; do
  [ $((SECONDS-T0)) -lt ${AB_UNTIL:-400} ] || break
  if [ $((r % 2)) = 1 ]; then order="main s20 b14 b16"; else order="b16 b14 s20 main"; fi
  for v in $order; do bench $v $r; done
done
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
python3 bench/gpu/winding-experiments-s19/steps.py $OUT/bench.log | tee $OUT/steps.txt
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all.jsonl main s20 > $OUT/summary.txt 2>&1
python3 - "$OUT/all.jsonl" <<'PY' | tee $OUT/totals.txt
import json, sys, collections
t = collections.defaultdict(list); inside = collections.defaultdict(set)
for line in open(sys.argv[1]):
    d = json.loads(line); k = (d["mesh"], d.get("mode")); t[(k, d["binary"])].append(d["time_ms"]["total"]); inside[k].add(d["inside_voxels"])
for k in sorted(inside):
    print(k, "inside equal" if len(inside[k]) == 1 else "INSIDE DIFFER", "|",
          "  ".join("%s %s" % (v, " ".join("%.1f" % x for x in t[(k, v)])) for v in ["main", "s20", "b14", "b16"]))
PY
date -u
