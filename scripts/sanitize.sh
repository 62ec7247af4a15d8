#!/usr/bin/env bash
# The unit tests and CLI cases under AddressSanitizer + UndefinedBehaviorSanitizer
# (GCC), in their own build directory (default build-asan). The VTK/ParaView
# tests are not included: ParaView's libraries are not instrumented and its
# Python/Qt start-up reports leaks of its own, so an ASan run of them says
# nothing about our code.
#   bash scripts/sanitize.sh
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HDT_ASAN_BUILD_DIR:-$root/build-asan}"
flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" -DCMAKE_SHARED_LINKER_FLAGS="$flags" \
  -DHDT_ENABLE_CUDA=OFF -DHDT_BUILD_PARAVIEW=OFF -DHDT_BUILD_FUZZERS=OFF >/dev/null
ninja -C "$build" -j"$(nproc)" hdt_tests hdt-voxelize

# detect_leaks: LeakSanitizer on; the suppressions name assimp's own leak
# (issue 12, defect 10). halt_on_error: a UBSan report fails the test.
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
export LSAN_OPTIONS="suppressions=$root/tests/fuzz/lsan.supp"
cd "$build"
# cli.mpi is left out: Open MPI's own allocations (MPI_Init/Finalize) read as leaks to
# LeakSanitizer; the normal ctest run covers it.
ctest --output-on-failure -j"$(nproc)" --no-tests=error -E '^(fuzz\.|pv|vtk|cli\.mpi$)'
