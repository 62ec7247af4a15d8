#!/bin/bash
# Session 19, classification inside T3: where its T3 time goes. Binaries in
# .devcarry/s19-fv.tar.xz (untracked): fv/hdt_gpu_bench (the branch),
# fv/nowait/ (the look-back never waits: a leaf's walk takes what has been
# published, wrong bytes) and fv/nolook/ (no look-back at all: exit parity 0,
# statuses, fences and the classified write kept, wrong bytes). twopass =
# the branch's binary with HDT_CUDA_FUSED_CLASSIFICATION=0.
. bench/gpu/call-setup.sh s19-fv
B=/tmp/fv
W=/tmp/s19work2; rm -rf $W; mkdir -p $W
bench() { # name round fused(0/1) binary
  HDT_CUDA_FUSED_CLASSIFICATION=$3 timeout 60 $4 --meshes .devdeps/meshes --mesh cycloidal-drive.ply --mesh tray-bottom.ply \
    --mesh stanford-dragon-100k.ply --res 8192 --modes solid --runs 5 --out $W/$1-$2.jsonl > $W/$1-$2.log 2>&1
  echo "bench $1 round $2 rc=$? at $((SECONDS-T0)) s"
}
for r in 1 2; do
  bench twopass $r 0 $B/hdt_gpu_bench; bench fused $r 1 $B/hdt_gpu_bench
  bench nowait $r 1 $B/nowait/hdt_gpu_bench; bench nolook $r 1 $B/nolook/hdt_gpu_bench
done
python3 bench/gpu/fused-s19/summary.py $W $OUT/all.jsonl > $OUT/summary.txt 2>&1; cat $OUT/summary.txt
date -u
