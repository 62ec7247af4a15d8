#!/usr/bin/env bash
# One device call for a kernel change: the new binaries' CUDA tests,
# memcheck and racecheck, then an A/B of two hdt_gpu_bench binaries
# (alternating processes, rounds while time is left) over the
# shared meshes at 8192^3, and ncu kernel times of both on one mesh.
# Run from a folder holding bench/gpu/ (this script, device-run.sh,
# ab_bench.sh), .devdeps (linked), bin-new/{hdt_cuda_tests,hdt_gpu_bench}
# and bin-base/hdt_gpu_bench. Everything lands in $OUT/results.tgz, the
# summary in $OUT/summary.txt.
#
#   OUT=... bench/gpu/kernel_ab_call.sh
# Env: AB_UNTIL (330: no A/B round starts later, seconds since the start), KT_BASE_UNTIL (380: the
#      base's kernel times only before it), PROFILE_COUNT (400), AB_ROUNDS (5), AB_RUNS (5), AB_MESHES (the ten), MEMCHECK_FILTER,
#      RACECHECK_FILTER, SANITIZE_TIMEOUT (150 s each), PROFILE_MESH (cycloidal-drive.ply);
#      VARIANTS ("NAME..." of bin-NAME/hdt_gpu_bench: also timed, with base and new, on
#      VARIANT_MESHES for VARIANT_ROUNDS rounds, none started after VARIANT_UNTIL).
set -u -o pipefail
ROOT=$(pwd)
FINAL=$OUT
W=/tmp/kab && rm -rf $W && mkdir -p $W/new $W/base $W/ab
t0=$SECONDS
OUT=$W/new DEVICE_BIN=$ROOT/bin-new bash bench/gpu/device-run.sh info tests
if grep -qE "FAILED|rc=[1-9]" $W/new/summary.txt; then
  echo "tests failed: no timings"; cp $W/new/summary.txt $FINAL/; tar czf $FINAL/results.tgz -C $W .; exit 1
fi
export LD_LIBRARY_PATH=$ROOT/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64:${LD_LIBRARY_PATH:-}
export HDT_MESHES_DIR=$ROOT/.devdeps/meshes PATH=/usr/local/cuda/bin:$PATH
cp $W/new/summary.txt $W/summary-sanitize.txt
for tool in memcheck racecheck; do
  s=$SECONDS
  if [ $tool = memcheck ]; then f=${MEMCHECK_FILTER:-'*CudaShapes*:CudaDriver.*:*CudaSharedMeshes*N1024*'}; else f=${RACECHECK_FILTER:-'*CudaShapes*R8*:CudaDriver.*'}; fi
  timeout ${SANITIZE_TIMEOUT:-150} compute-sanitizer --tool $tool $([ $tool = racecheck ] && echo --racecheck-report hazard) \
    --error-exitcode 9 $ROOT/bin-new/hdt_cuda_tests --gtest_filter="$f" > $W/$tool.log 2>&1
  echo "== $tool ($f): rc=$? in $((SECONDS - s)) s: $(grep -E 'SUMMARY|^\[  (PASSED|FAILED) ' $W/$tool.log | tr '\n' ' ')" | tee -a $W/summary-sanitize.txt
done
kerneltimes() { # $1: new or base
  OUT=$W/kt-$1 DEVICE_BIN=$ROOT/bin-$1 NCU_CLOCKS=none PROFILE_COUNT=${PROFILE_COUNT:-400} \
    PROFILE_MESH=${PROFILE_MESH:-cycloidal-drive.ply} bash bench/gpu/device-run.sh kerneltimes > /dev/null 2>&1
  { echo "== kerneltimes $1"; head -24 $W/kt-$1/kerneltimes.txt; } | tee -a $W/kerneltimes-both.txt
}
kerneltimes new
# A/B: per round, every mesh, each binary in turn (one process each), until the time is up
ab_run() { # "BINS" "MESHES" ROUNDS UNTIL(seconds since the start)
  local r m b
  for r in $(seq "$3"); do
    [ $((SECONDS - t0)) -lt $4 ] || { echo "ab: stopped before round $r of $1" >> $W/ab/ab.log; break; }
    for m in $2; do
      for b in $1; do
        timeout 120 $ROOT/bin-$b/hdt_gpu_bench --meshes .devdeps/meshes --mesh "$m" --res 8192 --modes surface,solid \
          --runs "${AB_RUNS:-5}" --out "$W/ab/ab-$b.jsonl" >> $W/ab/ab.log 2>&1 || echo "ab: rc=$? for $b $m" >> $W/ab/ab.log
      done
    done
    echo "ab: round $r of $1 done at $((SECONDS - t0)) s" >> $W/ab/ab.log
  done
}
meshes=${AB_MESHES:-"cycloidal-drive.ply stanford-dragon-100k.ply nefertiti.ply ogre.ply teapot.ply bracket.ply teapot-shell.ply fandisk.ply turbine-blade.ply tray-bottom.ply"}
ab_run "base new" "$meshes" "${AB_ROUNDS:-5}" "${AB_UNTIL:-330}"
# VARIANTS: more binaries (bin-NAME/hdt_gpu_bench) against base and new on VARIANT_MESHES
[ -n "${VARIANTS:-}" ] && ab_run "base new $VARIANTS" "${VARIANT_MESHES:-cycloidal-drive.ply stanford-dragon-100k.ply}" \
  "${VARIANT_ROUNDS:-3}" "${VARIANT_UNTIL:-400}"
python3 - $W/ab base new ${VARIANTS:-} <<'PY' | tee $W/ab/table.txt
import json, sys, os, statistics, collections
d, bins = sys.argv[1], sys.argv[2:]
rows = collections.defaultdict(lambda: collections.defaultdict(list))
for b in bins:
    for l in open(os.path.join(d, f"ab-{b}.jsonl")):
        r = json.loads(l); rows[(r["mesh"], "surface" if r["surface_only"] else "solid")][b].append(r["time_ms"])
print("mesh mode: binary processes total (diff to base) T2 T3 classify, medians over processes")
for (m, mode), per in sorted(rows.items()):
    med = {b: {p: statistics.median(x[p] for x in v) for p in v[0]} for b, v in per.items()}
    a = med["base"]
    for b in bins:
        if b not in med: continue
        n = med[b]
        print(f"{m[:22]:22} {mode:7} {b:6} {len(per[b])} total {n['total']:.3f} ({100*(n['total']/a['total']-1):+.1f}%)"
              f"  T2 {n['branching']:.3f} T3 {n['leaf']:.3f} cls {n['classify']:.3f}")
PY
if [ $((SECONDS - t0)) -lt ${KT_BASE_UNTIL:-380} ]; then kerneltimes base; fi
echo "total $((SECONDS - t0)) s"
cat $W/summary-sanitize.txt > $FINAL/summary.txt
cat $W/ab/table.txt $W/kerneltimes-both.txt >> $FINAL/summary.txt
tar czf $FINAL/results.tgz -C $W .
