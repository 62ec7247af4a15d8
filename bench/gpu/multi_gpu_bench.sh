#!/bin/bash
# multi_gpu_bench.sh BUILD_DIR MESH_DIR: hdt-voxelize-mpi with one rank per GPU
# (issue 15), K = 1, 2, 4, 8 up to the machine's device count, over meshes,
# resolutions and modes; every K > 1 file compared with the K = 1 file
# (tests/cli/compare_hdt.py: every volume section byte for byte).
# Environment: MULTIGPU_MESHES (file names in MESH_DIR; "dragon-1.6m" is made
# from the dragon by bench/gpu/subdivide_ply.py), MULTIGPU_RES, MULTIGPU_MODES,
# MULTIGPU_BIG (mesh:mode pairs also run at 65536), MULTIGPU_DEADLINE (seconds;
# later runs are skipped, and say so), MULTIGPU_GPUS, HDT_BENCH_BACKEND. Appends JSON lines (the CLI's --json plus
# ranks, wall_s, file_bytes, same_as_k1) to $OUT/multi-gpu-runs.jsonl.
set -uo pipefail
build=$1 meshes=$2
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${OUT:-/tmp}/multi-gpu-runs.jsonl
tmp=${TMPDIR:-/tmp}/hdt-multi-gpu
mkdir -p "$tmp" "$(dirname "$out")"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 PMIX_MCA_pcompress_base_silence_warning=1
backend=${HDT_BENCH_BACKEND:-cuda} # cpu, with MULTIGPU_GPUS=2: a dry run on a machine without a GPU
gpus=${MULTIGPU_GPUS:-$(nvidia-smi --query-gpu=name --format=csv,noheader | wc -l)}
gpu=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | head -1)
cores=$(nproc)
date=$(date -Iminutes)
deadline=$((SECONDS + ${MULTIGPU_DEADLINE:-480}))
ks=""; for k in 1 2 4 8; do [ "$k" -le "$gpus" ] && ks="$ks $k"; done
if [[ " ${MULTIGPU_MESHES:-} " == *" dragon-1.6m "* ]] && [ ! -f "$tmp/dragon-1.6m.ply" ]; then
  python3 "$root/bench/gpu/subdivide_ply.py" "$meshes/stanford-dragon-100k.ply" "$tmp/dragon-1.6m.ply" 2
fi
meshpath() { [ "$1" = dragon-1.6m ] && echo "$tmp/dragon-1.6m.ply" || echo "$meshes/$1"; }

one() { # mesh n mode: every K, compared with K = 1
  local mesh=$1 n=$2 mode=$3 k flag=""
  [ "$mode" = surface ] && flag=--surface-only
  for k in $ks; do
    if [ $SECONDS -ge $deadline ]; then echo "skipped (deadline): $mesh $n $mode K=$k"; continue; fi
    local t0=$(date +%s.%N)
    mpiexec --bind-to none -n "$k" "$build/hdt-voxelize-mpi" "$(meshpath "$mesh")" --resolution "$n" $flag \
      --backend "$backend" --threads $((cores / k)) --json --quiet -o "$tmp/k$k.hdt" > "$tmp/k$k.json" 2> "$tmp/k$k.err"
    local rc=$? wall=$(python3 -c "print($(date +%s.%N) - $t0)")
    local same=null
    if [ $rc -ne 0 ]; then echo "FAILED rc=$rc: $mesh $n $mode K=$k: $(tail -2 "$tmp/k$k.err")"; continue; fi
    if [ "$k" -gt 1 ]; then
      python3 "$root/tests/cli/compare_hdt.py" "$tmp/k1.hdt" "$tmp/k$k.hdt" > /dev/null && same=true || same=false
    fi
    python3 - "$tmp/k$k.json" "$k" "$wall" "$same" "$gpu" "$date" "$out" "$(stat -c %s "$tmp/k$k.hdt")" "$mode" <<'PY'
import json, sys
path, k, wall, same, gpu, date, out, size, mode = sys.argv[1:]
r = json.load(open(path))
r.update(rank_count=int(k), wall_s=float(wall), same_as_k1=json.loads(same), gpu=gpu, date=date,
         file_bytes=int(size), mode=mode, bench="multi_gpu_bench.sh")
open(out, "a").write(json.dumps(r) + "\n")
t = r["time_ms"]
print("%-26s N=%-5s %-7s K=%s phases(slowest) %.1f ms build %.0f ms write %.0f ms wall %.2f s peak %.1f GiB same=%s"
      % (r["mesh"].split("/")[-1], r["resolution"], mode, k, t["mapping"] + t["branching"] + t["leaf"] + t["classify"],
         t["total"], r["io_ms"]["write"], float(wall), r["peak_host_bytes"] / 2**30, same))
PY
  done
  rm -f "$tmp"/k*.hdt
}

for n in ${MULTIGPU_RES:-16384 32768}; do
  for mesh in ${MULTIGPU_MESHES:-stanford-dragon-100k.ply}; do
    for mode in ${MULTIGPU_MODES:-solid surface}; do one "$mesh" "$n" "$mode"; done
  done
done
for pair in ${MULTIGPU_BIG:-}; do one "${pair%%:*}" 65536 "${pair##*:}"; done
