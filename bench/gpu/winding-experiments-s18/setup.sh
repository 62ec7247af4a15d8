# Sourced by call.sh and call2.sh: the machine's environment, the binaries
# unpacked to $B (.devcarry/s18-lin.tar.xz, untracked: lin/hdt_cuda_tests,
# lin/hdt_gpu_bench of the branch and lin/broken/hdt_cuda_tests with H dropped
# from windingChainExpansion, built as in gpu-notes.md: build-devbin, Release,
# 90-real, no ParaView, no assimp, stripped), the work folder $W and bench().
. bench/gpu/call-setup.sh s18-lin
B=/tmp/lin
W=/tmp/s18work; rm -rf $W; mkdir -p $W
# One process of 4 builds a variant: bench name round linear-voxels
# (HDT_WINDING_LINEAR_VOXELS; 0 is the halving alone). BENCH_TIMEOUT: seconds (60).
bench() {
  HDT_WINDING_LINEAR_VOXELS=$3 HDT_WINDING_TRACE=1 timeout ${BENCH_TIMEOUT:-60} $B/hdt_gpu_bench --meshes .devdeps/meshes \
    --mesh teapot.ply --mesh ogre.ply --res 1024,8192 --root 8 --modes solid,winding --runs ${RUNS:-3} \
    --out $W/$1-$2.jsonl > $W/$1-$2.log 2>&1
  echo "bench $1 round $2 rc=$? at $((SECONDS-T0)) s"
}
