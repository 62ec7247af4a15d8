#!/bin/bash
# Run from the repository root with carry [".devdeps"] (binaries: setup.sh).
# Session 18: first-order leaf/uniform boxes (s18-linear). One binary, variants by
# HDT_WINDING_LINEAR_VOXELS: halving (0: the old code path), linear (default 64), l512 (512).
. bench/gpu/winding-experiments-s18/setup.sh
# correctness first (the part that must come back)
timeout 40 $B/broken/hdt_cuda_tests --gtest_filter='Shapes/CudaWinding.SameBytesAsCpu/*:CudaWindingSharedMeshes*' > $OUT/broken.log 2>&1
echo "broken rc=$? (must be nonzero); failed: $(grep -cE '^\[  FAILED  \] .*\(' $OUT/broken.log) at $((SECONDS-T0)) s"
timeout 150 compute-sanitizer --tool memcheck $B/hdt_cuda_tests --gtest_filter='*CudaWinding*:CudaDriver.Winding*:CudaRangeBuild.Winding*' > $OUT/memcheck.log 2>&1 &
MC=$!
timeout 145 $B/hdt_cuda_tests > $OUT/tests.log 2>&1; echo "tests rc=$? at $((SECONDS-T0)) s"
HDT_WINDING_LINEAR_VOXELS=8 timeout 60 $B/hdt_cuda_tests --gtest_filter='*CudaWinding*' > $OUT/tests512.log 2>&1; echo "tests 512 rc=$? at $((SECONDS-T0)) s"
wait $MC; echo "memcheck rc=$? at $((SECONDS-T0)) s"
grep -E "^\[  (PASSED|FAILED) |^\[  FAILED  \]" $OUT/tests.log | head -20
echo "tests OK lines: $(grep -c "^\[       OK \]" $OUT/tests.log), SKIPPED: $(grep -c "^\[  SKIPPED \] .*(" $OUT/tests.log)"
grep -E "^\[  (PASSED|FAILED) |^\[  FAILED  \]" $OUT/tests512.log | head -5
grep -E "ERROR SUMMARY|^\[  (PASSED|FAILED) |^\[  FAILED  \]" $OUT/memcheck.log | tail -4
echo "memcheck error lines: $(grep -cE "^========= +(Invalid|Program hit|Error|Uninitialized)" $OUT/memcheck.log), OK: $(grep -c "^\[       OK \]" $OUT/memcheck.log)"
bench halving 1 0; bench linear 1 64; bench l8 1 8; bench l8 2 8; bench linear 2 64; bench halving 2 0
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all.jsonl halving linear > $OUT/summary.txt 2>&1
python3 bench/gpu/winding-experiments-s15/summary.py $W /tmp/all2.jsonl halving l8 > $OUT/summary8.txt 2>&1
cat $OUT/summary.txt; head -12 $OUT/summary8.txt
date -u
