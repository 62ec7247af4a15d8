#!/bin/bash
# pack_device_bundles.sh [BUILD_DIR]: the two tarballs the GPU machine needs
# from this machine (it has no VTK, ParaView, Open MPI or Debian packages),
# from a build with ParaView, CUDA (arch 90) and MPI on (default: build/):
#   .devdeps/vtk-tests.tar.xz    hdt_vtk_tests and its ldd closure (step vtktests)
#   .devdeps/mpi-runtime.tar.xz  hdt-voxelize(-mpi) with Open MPI as one
#                                relocatable prefix (steps mpigpu, multigpu, labels)
# Minus libc, libm, libstdc++, libgcc, the loader and libcuda, which that
# machine has. Rebuild both after every change to core/, cuda/, filters/, apps/:
# the steps run whatever binaries the tarballs hold. bench/gpu/README.md explains.
set -euo pipefail
B=$(realpath "${1:-build}")
root=$(cd "$(dirname "$0")/../.." && pwd)
ninja -C "$B" hdt_vtk_tests hdt-voxelize hdt-voxelize-mpi
closure() { # FILE... -> the shared libraries they load, but the machine's own
  for f in "$@"; do ldd "$f" 2>/dev/null | awk '/=> \// {print $3}'; done | sort -u |
    grep -vE '/(libc|libm|libstdc\+\+|libgcc_s|ld-linux-x86-64|libcuda|libdl|libpthread|librt)\.so' || true
}
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
mkdir -p "$T/vtk/bin" "$T/vtk/lib"
cp "$B/tests/vtk/hdt_vtk_tests" "$T/vtk/bin/"
closure "$T/vtk/bin/hdt_vtk_tests" | xargs -r cp -L -t "$T/vtk/lib/"
tar -cJf "$root/.devdeps/vtk-tests.tar.xz" -C "$T/vtk" bin lib

P=$T/mpi/ompi
mkdir -p "$P/bin" "$P/lib/x86_64-linux-gnu" "$P/share"
cp -L /usr/bin/orterun "$P/bin/" && ln -s orterun "$P/bin/mpiexec"
cp -a /usr/lib/x86_64-linux-gnu/openmpi /usr/lib/x86_64-linux-gnu/pmix2 "$P/lib/x86_64-linux-gnu/"
cp -a /usr/share/openmpi "$P/share/"
cp "$B/apps/hdt-voxelize" "$B/apps/hdt-voxelize-mpi" "$P/bin/"
closure "$P"/bin/* $(find "$P/lib" -name '*.so*') | xargs -r cp -L -t "$P/lib/x86_64-linux-gnu/"
tar -cJf "$root/.devdeps/mpi-runtime.tar.xz" -C "$T/mpi" ompi
ls -lh "$root/.devdeps/vtk-tests.tar.xz" "$root/.devdeps/mpi-runtime.tar.xz"
