#!/bin/sh
# mpi_test.sh PVBATCH PLUGIN TMP: the HDT plugin across MPI ranks.
#  1. test_mpi.py serially (the reference), then under mpiexec with 1 to 4
#     ranks (oversubscribed: CI has 2 cores): every tree, the statistics, the
#     voxel surface, the written .hdt and the reader's shares equal serial;
#  2. mpi_render.py serially and on 4 ranks: the same picture;
#  3. mpi_htg_filters.py serially and on 2 and 3 ranks: ParaView's HTG filters
#     (ghost cells, depth limiter, threshold, contour, slice, clip) on the
#     distributed grid give the serial results.
set -e
pvbatch=$1 plugin=$2 tmp=$3
here=$(dirname "$0")
# Open MPI refuses root unless told (containers, CI).
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export PYTHONPATH="$here${PYTHONPATH:+:$PYTHONPATH}"
mpirun="mpiexec --oversubscribe"
rm -rf "$tmp" && mkdir -p "$tmp"
ref="$tmp/reference.json"
"$pvbatch" "$here/test_mpi.py" --plugin "$plugin" --tmp "$tmp" --reference "$ref" --write-reference
for k in 1 2 3 4; do
  $mpirun -n $k "$pvbatch" --mpi "$here/test_mpi.py" --plugin "$plugin" --tmp "$tmp" --reference "$ref"
done
sh "$here/with_display.sh" "$pvbatch" "$here/mpi_render.py" --plugin "$plugin" --out "$tmp/serial.png"
sh "$here/with_display.sh" $mpirun -n 4 "$pvbatch" --mpi "$here/mpi_render.py" --plugin "$plugin" --out "$tmp/ranks4.png"
"$pvbatch" "$here/compare_images.py" "$tmp/serial.png" "$tmp/ranks4.png"
filters="$tmp/htg-filters.json"
"$pvbatch" "$here/mpi_htg_filters.py" --plugin "$plugin" --tmp "$tmp" --reference "$filters" --write-reference
for k in 2 3; do
  $mpirun -n $k "$pvbatch" --mpi "$here/mpi_htg_filters.py" --plugin "$plugin" --tmp "$tmp" --reference "$filters"
done
echo "mpi_test: ok"
