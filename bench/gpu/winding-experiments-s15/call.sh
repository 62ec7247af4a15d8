#!/bin/bash
# s15-mem: the winding pass's device memory counted (budget, peak) and its
# counts only for the leaves that keep them. Run from the repository root
# with carry [".devdeps"]. Main's binaries: .devcarry/s15/main-bins.tar.xz
# (-> /tmp/s15main), ours: .devcarry/mem/bins.tar.xz (-> /tmp/mem).
# 1) A/B main vs mem, 2 processes each, alternating, HDT_WINDING_TRACE=1;
# 2) the broken-on-purpose binary on the bytes tests; 3) mem's whole
# hdt_cuda_tests beside memcheck on *CudaWinding*:CudaDriver.*; summary last.
set -u
ROOT=$(pwd)
export LD_LIBRARY_PATH=$ROOT/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64 HDT_MESHES_DIR=$ROOT/.devdeps/meshes
export PATH=/usr/local/cuda/bin:$PATH
OUT=${OUT:-/tmp/memout}; mkdir -p $OUT; T0=$SECONDS
tar xJf .devcarry/s15/main-bins.tar.xz -C /tmp && tar xJf .devcarry/mem/bins.tar.xz -C /tmp || { echo "unpack failed"; exit 1; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader; date -u
W=/tmp/memwork; rm -rf $W; mkdir -p $W # not under $OUT: at most 8 files come back
bench() { # binary-dir name round
  HDT_WINDING_TRACE=1 timeout 45 $1/hdt_gpu_bench --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply \
    --res 1024,8192 --root 8 --modes solid,winding --runs 3 --out $W/$2-$3.jsonl > $W/$2-$3.log 2>&1
  echo "bench $2 round $3 rc=$? at $((SECONDS-T0)) s"
}
bench /tmp/s15main main 1; bench /tmp/mem mem 1; bench /tmp/mem mem 2; bench /tmp/s15main main 2
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
timeout 25 /tmp/mem/broken/hdt_cuda_tests --gtest_filter='Shapes/CudaWinding.SameBytesAsCpu/*:CudaWindingCrossings.*' > $OUT/broken.log 2>&1
echo "broken rc=$? (must be nonzero) at $((SECONDS-T0)) s"; grep -cE "^\[  FAILED  \] .*\(" $OUT/broken.log
LEFT=$((228 - (SECONDS - T0)))
timeout $LEFT compute-sanitizer --tool memcheck /tmp/mem/hdt_cuda_tests --gtest_filter='*CudaWinding*:CudaDriver.*:CudaRangeBuild.Winding*' > $OUT/memcheck.log 2>&1 &
MC=$!
timeout $((LEFT - 5)) /tmp/mem/hdt_cuda_tests > $OUT/tests.log 2>&1; echo "tests rc=$? at $((SECONDS-T0)) s"
wait $MC; echo "memcheck rc=$? at $((SECONDS-T0)) s"
grep -E "^\[  (PASSED|FAILED) |^\[  FAILED  \]" $OUT/tests.log | head -20
echo "tests OK lines: $(grep -c "^\[       OK \]" $OUT/tests.log), SKIPPED: $(grep -c "^\[  SKIPPED \] .*(" $OUT/tests.log)"
grep -E "ERROR SUMMARY|^\[  (PASSED|FAILED) |^\[  FAILED  \]|^\[       OK \]" $OUT/memcheck.log | tail -8
echo "memcheck error lines: $(grep -cE "^========= +(Invalid|Program hit|Error|Uninitialized)" $OUT/memcheck.log)"; grep -c "^\[       OK \]" $OUT/memcheck.log
python3 .devcarry/mem/summary.py $W $OUT/all.jsonl > $OUT/summary.txt 2>&1; cat $OUT/summary.txt
date -u
