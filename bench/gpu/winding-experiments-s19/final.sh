#!/bin/bash
# Session 19's final main (0741cdc): every device test, memcheck on the
# winding tests, one bench process. Binaries in .devcarry/s19-final.tar.xz
# (untracked): final/hdt_cuda_tests, final/hdt_gpu_bench, built as in gpu-notes.md.
. bench/gpu/call-setup.sh s19-final
B=/tmp/final
timeout 90 compute-sanitizer --tool memcheck $B/hdt_cuda_tests --gtest_filter='*Winding*' > $OUT/memcheck.log 2>&1 &
MC=$!
timeout 150 $B/hdt_cuda_tests > $OUT/tests.log 2>&1; echo "tests rc=$? at $((SECONDS-T0)) s"
wait $MC; echo "memcheck rc=$? at $((SECONDS-T0)) s"
echo "tests: $(grep -E '^\[  (PASSED|FAILED) ' $OUT/tests.log | tr '\n' ' ') OK lines $(grep -c '^\[       OK \]' $OUT/tests.log)"
grep -E "^\[  FAILED  \] .*\(" $OUT/tests.log | head -5
echo "memcheck: $(grep -E 'ERROR SUMMARY|^\[  (PASSED|FAILED) ' $OUT/memcheck.log | tr '\n' ' ')"
timeout 60 $B/hdt_gpu_bench --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply --mesh cycloidal-drive.ply --res 8192 \
  --root 8 --modes solid,winding --runs 3 --out $OUT/bench.jsonl > $OUT/bench.log 2>&1
echo "bench rc=$? at $((SECONDS-T0)) s"; grep -E "^(teapot|ogre|cycloidal)" $OUT/bench.log
date -u
