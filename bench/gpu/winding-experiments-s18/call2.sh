#!/bin/bash
# Run from the repository root with carry [".devdeps"] (binaries: setup.sh).
# Session 18, final s18-linear (first order in the fresh leaves only): whole tests, broken binary, short A/B.
. bench/gpu/winding-experiments-s18/setup.sh
BENCH_TIMEOUT=40
deviceTests $B/hdt_cuda_tests 'CudaWindingRefined.*:Shapes/CudaWinding.SameBytesAsCpu/*' 45 60
timeout 20 $B/broken/hdt_cuda_tests --gtest_filter='*CudaWinding*' > $OUT/broken.log 2>&1
echo "broken rc=$? (must be nonzero); failed: $(grep -cE '^\[  FAILED  \] .*\(' $OUT/broken.log) at $((SECONDS-T0)) s"
grep -E "^\[  FAILED  \] .*\(" $OUT/broken.log | head -5
bench halving 1 0; bench linear 1 64; bench linear 2 64; bench halving 2 0
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all.jsonl halving linear > $OUT/summary.txt 2>&1
head -10 $OUT/summary.txt
grep "# CUDA driver: winding pass [0-9]" $OUT/bench.log | sed 's/ of which host tree (the rest of its build, started with the build)//' | cut -c1-200
date -u
