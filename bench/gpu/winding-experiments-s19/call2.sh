#!/bin/bash
# Session 19: launch bounds on the box kernels, more processes. Binaries in
# .devcarry/s19-lb.tar.xz (untracked), all of 44a4894 (the template kernel):
# lb/t/hdt_gpu_bench as it is, lb/b12/ + bounds12.patch (every box kernel at
# most 80 registers), lb/b12x/ + bounds12x.patch (the same but the first-order
# kernel, left at its 144); hdt_cuda_tests of b12 and b12x. Built as in
# gpu-notes.md (build-devbin: Release, 90-real, no ParaView, no assimp), stripped.
. bench/gpu/call-setup.sh s19-lb
B=/tmp/lb
for v in b12 b12x; do
  timeout 90 $B/$v/hdt_cuda_tests --gtest_filter='*Winding*' > $OUT/tests-$v.log 2>&1
  echo "tests $v rc=$? at $((SECONDS-T0)) s: $(grep -E '^\[  (PASSED|FAILED) ' $OUT/tests-$v.log | tr '\n' ' ')"
done
W=/tmp/s19lb; rm -rf $W; mkdir -p $W
bench() { # name round
  HDT_WINDING_TRACE=1 timeout 60 $B/$1/hdt_gpu_bench --meshes .devdeps/meshes --mesh teapot.ply --mesh ogre.ply --res 8192 \
    --root 8 --modes winding --runs 3 --out $W/$1-$2.jsonl > $W/$1-$2.log 2>&1
  echo "bench $1 round $2 rc=$? at $((SECONDS-T0)) s"
}
for r in 1 2 3 4; do
  [ $((SECONDS-T0)) -lt ${AB_UNTIL:-240} ] || break
  if [ $((r % 2)) = 1 ]; then bench t $r; bench b12 $r; bench b12x $r; else bench b12x $r; bench b12 $r; bench t $r; fi
done
for f in $W/*-?.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
python3 bench/gpu/winding-experiments-s19/steps.py $OUT/bench.log | tee $OUT/steps.txt
python3 bench/gpu/winding-experiments-s15/summary.py $W $OUT/all.jsonl t b12 > /dev/null 2>&1
date -u
