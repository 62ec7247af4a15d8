#!/bin/bash
# Session 19: leafBoxesKernel<LINEAR> (the surface leaves' pass without the
# first order's code and registers) against main, then fused-s19/call2.sh.
# Run from the repository root with carry [".devdeps"]. Binaries in
# .devcarry/s19-lt.tar.xz (untracked): lt/hdt_cuda_tests and lt/hdt_gpu_bench
# of the branch, lt/main/hdt_gpu_bench of main (da81f2c), lt/bounds12/hdt_gpu_bench
# (the branch + bounds12.patch: 12 blocks of 64 threads an SM for the box
# kernels, at most 80 registers, some spilled); built as in
# gpu-notes.md (build-devbin: Release, 90-real, no ParaView, no assimp), stripped.
. bench/gpu/call-setup.sh s19-lt
B=/tmp/lt
deviceTests $B/hdt_cuda_tests 'CudaWindingRefined.*:Shapes/CudaWinding.SameBytesAsCpu/*'
W=/tmp/s19lt; rm -rf $W; mkdir -p $W
bench() { # name round binary
  HDT_WINDING_TRACE=1 timeout 60 $3 --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply --res 1024,8192 --root 8 \
    --modes solid,winding --runs 3 --out $W/$1-$2.jsonl > $W/$1-$2.log 2>&1
  echo "bench $1 round $2 rc=$? at $((SECONDS-T0)) s"
}
bench main 1 $B/main/hdt_gpu_bench; bench template 1 $B/hdt_gpu_bench; bench bounds12 1 $B/bounds12/hdt_gpu_bench
bench bounds12 2 $B/bounds12/hdt_gpu_bench; bench template 2 $B/hdt_gpu_bench; bench main 2 $B/main/hdt_gpu_bench
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
cat $W/*.jsonl > $OUT/all.jsonl
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all-summary.jsonl main template > $OUT/summary.txt 2>&1
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all-summary-b.jsonl template bounds12 > $OUT/summary-b.txt 2>&1
head -30 $OUT/summary.txt; head -9 $OUT/summary-b.txt
mkdir -p $OUT/fused && OUT=$OUT/fused bash bench/gpu/fused-s19/call2.sh
date -u
