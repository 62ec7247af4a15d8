#!/usr/bin/env bash
# The device call of branch s12-18c (bench/results/gpu-notes.md, "T3: transposed staging"): run from a
# folder two levels below the repository root (e.g. .devcarry/NAME/) holding *.tar.xz of bin-NAME/
# folders (bin-new with hdt_cuda_tests), with .devdeps/lib and the meshes carried:
#   TESTS=1 KT="base new" BINS="base new" MESHES="cycloidal-drive.ply ..." ROUNDS=3 OUT=$OUT bash t3_variants_call.sh
# KT_METRICS / KT_COUNT: the ncu metrics and launches of leafKernel (cycloidal-drive 8192^3 solid, boost clocks).
# s12-18c device step: unpack binaries, tests of bin-new, A/B of bench binaries, ncu T3 times.
# Env: BINS ("base new ..."), MESHES, ROUNDS, AB_UNTIL, TESTS (1/0), TFILTER, SAN (memcheck racecheck), KT (bins for ncu)
set -u
HERE=$(cd "$(dirname "$0")" && pwd); ROOT=$(cd "$HERE/../.." && pwd)
cd "$HERE"; t0=$SECONDS
for f in *.tar.xz; do tar -xJf "$f"; done
export LD_LIBRARY_PATH=$ROOT/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64:${LD_LIBRARY_PATH:-}
export HDT_MESHES_DIR=$ROOT/.devdeps/meshes PATH=/usr/local/cuda/bin:$PATH
S=$OUT/summary.txt; date -u > $S; nvidia-smi --query-gpu=name,driver_version --format=csv,noheader >> $S
if [ "${TESTS:-1}" = 1 ]; then
  s=$SECONDS; timeout ${TTIME:-200} bin-new/hdt_cuda_tests --gtest_filter="${TFILTER:-*}" --gtest_color=no > $OUT/tests.log 2>&1
  echo "tests: rc=$? in $((SECONDS-s)) s: $(grep -E '^\[  (PASSED|FAILED|SKIPPED) ' $OUT/tests.log | tr '\n' ' ')" >> $S
  grep -E '^\[  FAILED  \]' $OUT/tests.log | head -20 >> $S
fi
for tool in ${SAN:-}; do
  s=$SECONDS
  if [ $tool = memcheck ]; then f=${MEMCHECK_FILTER:-'*CudaShapes*:CudaDriver.*:*CudaSharedMeshes*N1024*'}; else f=${RACECHECK_FILTER:-'*CudaShapes*R8*:CudaDriver.*'}; fi
  timeout ${SANITIZE_TIMEOUT:-120} compute-sanitizer --tool $tool $([ $tool = racecheck ] && echo --racecheck-report hazard) \
    --error-exitcode 9 bin-new/hdt_cuda_tests --gtest_filter="$f" > $OUT/$tool.log 2>&1
  echo "== $tool ($f): rc=$? in $((SECONDS - s)) s: $(grep -E 'SUMMARY|^\[  (PASSED|FAILED) ' $OUT/$tool.log | tr '\n' ' ')" >> $S
done
for b in ${KT:-}; do
  s=$SECONDS
  timeout 100 ncu --clock-control none --metrics ${KT_METRICS:-gpu__time_duration.sum,smsp__inst_executed.sum} -k regex:leafKernel -c ${KT_COUNT:-3} --csv bin-$b/hdt_gpu_bench --meshes $ROOT/.devdeps/meshes \
    --mesh ${KT_MESH:-cycloidal-drive.ply} --res 8192 --modes solid --runs 1 --out /tmp/kt.jsonl 2>/dev/null | grep '^"' > $OUT/kt-$b.csv
  echo "kt $b ($((SECONDS-s)) s): $(grep -vE "Metric Name" $OUT/kt-$b.csv | awk -F'","' '{print $(NF-2)"="$NF}' | tr -d '"' | tr '\n' ' ')" >> $S
done
for r in $(seq ${ROUNDS:-2}); do
  [ $((SECONDS - t0)) -lt ${AB_UNTIL:-200} ] || { echo "ab: stopped before round $r" >> $S; break; }
  for m in ${MESHES:-cycloidal-drive.ply}; do for b in ${BINS:-base new}; do
    timeout 60 bin-$b/hdt_gpu_bench --meshes $ROOT/.devdeps/meshes --mesh $m --res 8192 --modes ${MODES:-solid,surface} --runs 5 \
      --out $OUT/ab-$b.jsonl >> $OUT/ab.log 2>&1 || echo "ab rc=$? $b $m" >> $S
  done; done
  echo "round $r done at $((SECONDS-t0)) s" >> $S
done
python3 - $OUT ${BINS:-base new} <<'PY' >> $S
import json, sys, os, statistics, collections
d, bins = sys.argv[1], sys.argv[2:]
rows = collections.defaultdict(lambda: collections.defaultdict(list))
for b in bins:
    p = os.path.join(d, f"ab-{b}.jsonl")
    if not os.path.exists(p): continue
    for l in open(p):
        r = json.loads(l); rows[(r["mesh"], "surface" if r["surface_only"] else "solid")][b].append(r["time_ms"])
for (m, mode), per in sorted(rows.items()):
    med = {b: {p: statistics.median(x[p] for x in v) for p in v[0]} for b, v in per.items()}
    a = med.get("base")
    for b in bins:
        if b not in med: continue
        n = med[b]
        print(f"{m[:22]:22} {mode:7} {b:6} {len(per[b])} total {n['total']:.3f} ({100*(n['total']/a['total']-1):+.1f}%)"
              f"  T2 {n['branching']:.3f} T3 {n['leaf']:.3f} cls {n['classify']:.3f}  [{' '.join('%.3f' % x['total'] for x in per[b])}]")
PY
echo "total $((SECONDS-t0)) s" >> $S
cat $S
