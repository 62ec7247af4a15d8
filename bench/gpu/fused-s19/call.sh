#!/bin/bash
# Session 19, classification inside T3 (branch s19-fused): one device call.
# Run from the repository root with carry [".devdeps"]. Binaries in
# .devcarry/s19-fused.tar.xz (untracked): fused/hdt_cuda_tests and
# fused/hdt_gpu_bench of the branch, fused/broken/hdt_cuda_tests with the
# look-back's stop lane taking its aggregate instead of its inclusive value,
# fused/main/hdt_gpu_bench of main; built as in gpu-notes.md (build-devbin:
# Release, 90-real, no ParaView, no assimp), stripped.
# The A/B is one binary: HDT_CUDA_FUSED_CLASSIFICATION=0 (two passes, main's
# path) against the default (inside T3), alternating processes.
. bench/gpu/call-setup.sh s19-fused
B=/tmp/fused
deviceTests $B/hdt_cuda_tests '*CudaDense*:*CudaShapes*R8*solid:CudaDriver.*:*CudaSharedMeshes*N1024*' 150 200
timeout 90 compute-sanitizer --tool racecheck --racecheck-report hazard --error-exitcode 9 $B/hdt_cuda_tests \
  --gtest_filter='*CudaDense*closed*:*CudaShapes*sphere*R8*solid' > $OUT/racecheck.log 2>&1
echo "racecheck rc=$? at $((SECONDS-T0)) s"
timeout 60 $B/broken/hdt_cuda_tests --gtest_filter='*CudaShapes*_solid:*CudaDense*:CudaTwoPass*:*CudaSharedMeshes*' > $OUT/broken.log 2>&1
echo "broken rc=$? (must be nonzero); failed: $(grep -cE '^\[  FAILED  \] .*\(' $OUT/broken.log) at $((SECONDS-T0)) s"
echo "racecheck: $(grep -E 'RACECHECK SUMMARY|^\[  (PASSED|FAILED) ' $OUT/racecheck.log | tr '\n' ' ')"
W=/tmp/s19work; rm -rf $W; mkdir -p $W
MESHES=${MESHES:-"cycloidal-drive.ply stanford-dragon-100k.ply nefertiti.ply ogre.ply teapot.ply bracket.ply teapot-shell.ply fandisk.ply turbine-blade.ply tray-bottom.ply"}
bench() { # name round fused(0/1) [binary]
  local args=""; for m in $MESHES; do args="$args --mesh $m"; done
  HDT_CUDA_FUSED_CLASSIFICATION=$3 timeout ${BENCH_TIMEOUT:-90} ${4:-$B/hdt_gpu_bench} --meshes .devdeps/meshes $args \
    --res 8192 --modes surface,solid --runs ${RUNS:-5} --out $W/$1-$2.jsonl > $W/$1-$2.log 2>&1
  echo "bench $1 round $2 rc=$? at $((SECONDS-T0)) s"
}
for r in $(seq ${ROUNDS:-3}); do
  [ $((SECONDS-T0)) -lt ${AB_UNTIL:-420} ] || break
  if [ $((r % 2)) = 1 ]; then bench twopass $r 0; bench fused $r 1; else bench fused $r 1; bench twopass $r 0; fi
done
[ $((SECONDS-T0)) -lt ${AB_UNTIL:-420} ] && bench main 1 0 $B/main/hdt_gpu_bench
for f in $W/*.log; do echo "=== $(basename $f)"; cat $f; done > $OUT/bench.log
python3 bench/gpu/fused-s19/summary.py $W $OUT/all.jsonl > $OUT/summary.txt 2>&1; cat $OUT/summary.txt
date -u
