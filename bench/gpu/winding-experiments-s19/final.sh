#!/bin/bash
# Session 19's final main (0741cdc): every device test, memcheck on the
# winding tests, one bench process. Binaries in .devcarry/s19-final.tar.xz
# (untracked): final/hdt_cuda_tests, final/hdt_gpu_bench, built as in gpu-notes.md.
. bench/gpu/call-setup.sh s19-final
B=/tmp/final
deviceTests $B/hdt_cuda_tests '*Winding*'
timeout 60 $B/hdt_gpu_bench --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply --mesh cycloidal-drive.ply --res 8192 \
  --root 8 --modes solid,winding --runs 3 --out $OUT/bench.jsonl > $OUT/bench.log 2>&1
echo "bench rc=$? at $((SECONDS-T0)) s"; grep -E "^(teapot|ogre|cycloidal)" $OUT/bench.log
date -u
