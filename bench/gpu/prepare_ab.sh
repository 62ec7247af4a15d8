#!/usr/bin/env bash
# prepareMesh of two or more source trees side by side on one machine, CPU only:
# each tree's core/src built with g++ -O3 (no CMake, no CUDA), the driver
# bench/gpu/prepare_ab.cpp linked to each, then the trees taken in turn, two
# rounds, one process a run (first call and best of 8 more).
#
#   bench/gpu/prepare_ab.sh NAME=TREE...     e.g. base=old new=.
# A tree is a directory with core/ and bench/gpu/subdivide.hpp, e.g. a base
# commit's: mkdir old && git archive BASE core bench/gpu/subdivide.hpp | tar -x -C old
# Meshes from .devdeps/meshes (PREPARE_AB_MESHES: "MESH:SUBDIVIDE ..."). Run from
# the repository root (on the GPU machine: as device-run.sh, .devdeps carried).
set -u
ROOT=$(pwd) DEPS=$(pwd)/.devdeps
export LD_LIBRARY_PATH=$DEPS/lib/x86_64-linux-gnu:${LD_LIBRARY_PATH:-}
build() { # name tree
  local o=/tmp/prepare-ab-$1 tree=$2 numbers=""
  mkdir -p "$o"
  grep -q "double numbers" "$tree/core/include/hdt/mesh.hpp" && numbers=-DHAS_NUMBERS
  for f in "$tree"/core/src/*.cpp; do
    echo "g++ -O3 -DNDEBUG -std=c++17 -DHDT_HAVE_ZSTD=1 -I$tree/core/include -I$tree/core/src -I$DEPS/include -c $f -o $o/$(basename "$f").o"
  done | xargs -P "$(nproc)" -I{} sh -c '{}' &&
    g++ -O3 -DNDEBUG -std=c++17 $numbers -I"$tree/core/include" -I"$tree/bench/gpu" -I"$DEPS/include" \
      "$ROOT/bench/gpu/prepare_ab.cpp" "$o"/*.o -L"$DEPS/lib/x86_64-linux-gnu" -ltbb -lzstd -lz -lpthread -o "$o/ab"
}
names=()
for spec in "$@"; do
  build "${spec%%=*}" "${spec#*=}" || { echo "build of $spec failed"; exit 1; }
  names+=("${spec%%=*}")
done
echo "built on $(nproc) cores"
for spec in ${PREPARE_AB_MESHES:-stanford-dragon-100k:0 nefertiti:0 cycloidal-drive:0 stanford-dragon-100k:1 stanford-dragon-100k:2}; do
  for round in 1 2; do
    for n in "${names[@]}"; do echo -n "$n "; "/tmp/prepare-ab-$n/ab" "$DEPS/meshes/${spec%%:*}.ply" "${spec##*:}" 8; done
  done
done
