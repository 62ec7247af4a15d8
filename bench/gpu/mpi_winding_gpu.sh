#!/bin/bash
# The winding-number pass of hdt-voxelize-mpi on the joining rank's GPU
# (applyInsideTestAfterPhases): an open mesh under Auto, 1-2 ranks on the
# machine's GPU against 2 CPU ranks (the pass on rank 0's host) and the serial
# CUDA build; every file compared with the serial one (the CPU ranks' apart
# from the statistics section, which names the driver). Run from the repository
# root with .devdeps/mpi-runtime.tar.xz (bench/gpu/pack_device_bundles.sh).
# MPI_MESH (teapot.ply), MPI_RES ("2048 4096"), MPI_REPS (2); GPU_BACKEND=auto
# runs the script on a machine without a GPU (a dry run: everything on the CPU).
set -u
ROOT=$(pwd); OUT=${OUT:-/tmp/out-mpi}; mkdir -p $OUT
D=/tmp/hdt-mpi; rm -rf $D && mkdir -p $D && tar -xJf .devdeps/mpi-runtime.tar.xz -C $D
export OPAL_PREFIX=$D/ompi PATH=$D/ompi/bin:$PATH LD_LIBRARY_PATH=$D/ompi/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-} \
  OMPI_MCA_btl=self,vader TMPDIR=/tmp OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
M=$ROOT/.devdeps/meshes/${MPI_MESH:-teapot.ply}; J=$OUT/mpi-winding.jsonl; : > $J
for N in ${MPI_RES:-2048 4096}; do
  hdt-voxelize $M --resolution $N --backend ${GPU_BACKEND:-cuda} --json --quiet -o /tmp/serial.hdt > /tmp/serial.json
  python3 -c "import json;r=json.load(open('/tmp/serial.json'));r.update(run='serial-cuda');print(json.dumps(r))" >> $J
  for run in "1 ${GPU_BACKEND:-cuda}" "2 ${GPU_BACKEND:-cuda}" "2 cpu"; do
    set -- $run
    for rep in $(seq ${MPI_REPS:-2}); do
      t0=$(date +%s.%N)
      timeout 120 mpiexec --oversubscribe --bind-to none -n $1 hdt-voxelize-mpi $M --resolution $N --backend $2 --json --quiet -o /tmp/r.hdt > /tmp/r.json 2> /tmp/r.err
      rc=$?; wall=$(python3 -c "print($(date +%s.%N) - $t0)")
      # The statistics section names the driver: CPU ranks' files against the
      # serial CUDA file compare everything else.
      flag=; [ "$2" = cpu ] && flag=--any-backend
      same=$(python3 tests/cli/compare_hdt.py $flag /tmp/serial.hdt /tmp/r.hdt > /dev/null 2>&1 && echo same || echo DIFFERENT)
      python3 -c "
import json;r=json.load(open('/tmp/r.json'));r.update(run='mpi-$1-$2',rep=$rep,wall_s=$wall,file='$same',rc=$rc);print(json.dumps(r))" >> $J || { echo "rc=$rc"; tail -3 /tmp/r.err; }
    done
  done
done
python3 - $J <<'PY'
import json, sys
for l in open(sys.argv[1]):
    r = json.loads(l); t = r['time_ms']
    print("%-14s N=%-5d %-8s total %8.1f ms classify %8.1f ms inside %d %s %s" % (r['run'], r['resolution'], r.get('backend',''),
          t['total'], t['classify'], r['inside_voxels'], r.get('inside_test',''), r.get('file','')))
PY
