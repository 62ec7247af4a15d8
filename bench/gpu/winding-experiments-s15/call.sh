#!/bin/bash
# A/B of two builds of hdt_gpu_bench + hdt_cuda_tests on the GPU machine
# (written for s15-mem, reused since). Run from the repository root with
# carry [".devdeps", ".devcarry"]. Each tarball unpacks to /tmp/<dir>/ with
# hdt_gpu_bench, hdt_cuda_tests and broken/hdt_cuda_tests:
#   A: $A_TAR -> /tmp/$A_DIR, named $A_NAME (default: main, .devcarry/s15/main-bins.tar.xz)
#   B: $B_TAR -> /tmp/$B_DIR, named $B_NAME (default: mem, .devcarry/mem/bins.tar.xz)
# 1) A/B, 2 processes each, alternating A B B A, HDT_WINDING_TRACE=1;
# 2) B's broken-on-purpose binary on $BROKEN_FILTER (must fail; under
#    memcheck when BROKEN_MEMCHECK=1: must report errors); 3) B's whole
# hdt_cuda_tests beside memcheck on the winding and driver tests; summary last.
# BUDGET: seconds the whole call may take (default 228); RUNS: builds a process (3).
set -u
ROOT=$(pwd)
export LD_LIBRARY_PATH=$ROOT/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64 HDT_MESHES_DIR=$ROOT/.devdeps/meshes
export PATH=/usr/local/cuda/bin:$PATH
A_TAR=${A_TAR:-.devcarry/s15/main-bins.tar.xz} A_DIR=${A_DIR:-s15main} A_NAME=${A_NAME:-main}
B_TAR=${B_TAR:-.devcarry/mem/bins.tar.xz} B_DIR=${B_DIR:-mem} B_NAME=${B_NAME:-mem}
BROKEN_FILTER=${BROKEN_FILTER:-Shapes/CudaWinding.SameBytesAsCpu/*:CudaWindingCrossings.*}
OUT=${OUT:-/tmp/memout}; mkdir -p $OUT; T0=$SECONDS
tar xJf $A_TAR -C /tmp && tar xJf $B_TAR -C /tmp || { echo "unpack failed"; exit 1; }
A=/tmp/$A_DIR B=/tmp/$B_DIR
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader; date -u
W=/tmp/memwork; rm -rf $W; mkdir -p $W # not under $OUT: at most 8 files come back
bench() { # binary-dir name round
  HDT_WINDING_TRACE=1 timeout 45 $1/hdt_gpu_bench --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply \
    --res 1024,8192 --root 8 --modes solid,winding --runs ${RUNS:-3} --out $W/$2-$3.jsonl > $W/$2-$3.log 2>&1
  echo "bench $2 round $3 rc=$? at $((SECONDS-T0)) s"
}
bench $A $A_NAME 1; bench $B $B_NAME 1; bench $B $B_NAME 2; bench $A $A_NAME 2
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
if [ "${BROKEN_MEMCHECK:-0}" = 1 ]; then
  timeout 60 compute-sanitizer --tool memcheck $B/broken/hdt_cuda_tests --gtest_filter="$BROKEN_FILTER" > $OUT/broken.log 2>&1
  echo "broken under memcheck rc=$? (must be nonzero) at $((SECONDS-T0)) s"; grep "ERROR SUMMARY" $OUT/broken.log
else
  timeout 25 $B/broken/hdt_cuda_tests --gtest_filter="$BROKEN_FILTER" > $OUT/broken.log 2>&1
  echo "broken rc=$? (must be nonzero) at $((SECONDS-T0)) s"
fi
grep -cE "^\[  FAILED  \] .*\(" $OUT/broken.log
LEFT=$((${BUDGET:-228} - (SECONDS - T0)))
timeout $LEFT compute-sanitizer --tool memcheck $B/hdt_cuda_tests --gtest_filter='*CudaWinding*:CudaDriver.*:CudaRangeBuild.Winding*' > $OUT/memcheck.log 2>&1 &
MC=$!
timeout $((LEFT - 5)) $B/hdt_cuda_tests > $OUT/tests.log 2>&1; echo "tests rc=$? at $((SECONDS-T0)) s"
wait $MC; echo "memcheck rc=$? at $((SECONDS-T0)) s"
grep -E "^\[  (PASSED|FAILED) |^\[  FAILED  \]" $OUT/tests.log | head -20
echo "tests OK lines: $(grep -c "^\[       OK \]" $OUT/tests.log), SKIPPED: $(grep -c "^\[  SKIPPED \] .*(" $OUT/tests.log)"
grep -E "ERROR SUMMARY|^\[  (PASSED|FAILED) |^\[  FAILED  \]|^\[       OK \]" $OUT/memcheck.log | tail -8
echo "memcheck error lines: $(grep -cE "^========= +(Invalid|Program hit|Error|Uninitialized)" $OUT/memcheck.log)"; grep -c "^\[       OK \]" $OUT/memcheck.log
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all.jsonl $A_NAME $B_NAME > $OUT/summary.txt 2>&1; cat $OUT/summary.txt
date -u
