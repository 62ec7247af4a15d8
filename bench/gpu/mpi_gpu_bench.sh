#!/bin/bash
# mpi_gpu_bench.sh BUILD_DIR MESH [RESOLUTIONS...]: hdt-voxelize-mpi with 1 to 4
# ranks sharing the machine's GPU(s) (issue 14: device selection and overlap;
# no speed-up expected on one GPU), against the serial hdt-voxelize on CUDA.
# Needs a build with CUDA and MPI (cmake -DHDT_ENABLE_CUDA=ON -DHDT_WITH_MPI=ON;
# Debian: libopenmpi-dev openmpi-bin). Each rank builds on device
# (local rank mod device count) and builds its own range of root cells
# (makeCudaRangeBuild; one rank: the one-piece build).
# Appends JSON lines to bench/results/mpi-gpu-runs.jsonl and checks every
# result against the serial file (tests/cli/compare_hdt.py).
set -euo pipefail
build=$1 mesh=$2
shift 2
resolutions=${*:-2048 4096}
backend=${HDT_BENCH_BACKEND:-cuda} # cpu: a dry run of this script on a machine without a GPU
root=$(cd "$(dirname "$0")/../.." && pwd)
out="$root/bench/results/mpi-gpu-runs.jsonl"
tmp=${TMPDIR:-/tmp}/hdt-mpi-gpu
mkdir -p "$tmp"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
gpu=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1 || true)
date=$(date -Iminutes)
for n in $resolutions; do
  "$build/apps/hdt-voxelize" "$mesh" --resolution "$n" --backend "$backend" --json --quiet -o "$tmp/serial.hdt" > "$tmp/serial.json"
  for k in 1 2 3 4; do
    for rep in 1 2 3; do
      t0=$(date +%s.%N)
      mpiexec --oversubscribe --bind-to none -n "$k" "$build/apps/hdt-voxelize-mpi" "$mesh" --resolution "$n" \
        --backend "$backend" --json --quiet -o "$tmp/r$k.hdt" > "$tmp/r$k.json"
      wall=$(python3 -c "print($(date +%s.%N) - $t0)")
      python3 "$root/tests/cli/compare_hdt.py" "$tmp/serial.hdt" "$tmp/r$k.hdt" > /dev/null
      python3 - "$tmp/r$k.json" "$k" "$rep" "$wall" "$gpu" "$date" "$out" <<'PY'
import json, sys
path, k, rep, wall, gpu, date, out = sys.argv[1:]
r = json.load(open(path))
r.update(rank_count=int(k), rep=int(rep), wall_s=float(wall), gpu=gpu, date=date, bench="mpi_gpu_bench.sh")
open(out, "a").write(json.dumps(r) + "\n")
print("N=%s ranks=%s rep=%s build %.0f ms wall %.2f s" % (r["resolution"], k, rep, r["time_ms"]["total"], float(wall)))
PY
    done
  done
done
