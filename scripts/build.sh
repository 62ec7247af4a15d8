#!/usr/bin/env bash
# Configures (Ninja, Release) into build/ and builds with all cores.
#   bash scripts/build.sh [extra cmake arguments, e.g. -DHDT_BUILD_PARAVIEW=OFF]
# The CUDA driver is built when nvcc >= 12 is found (CMake's default for
# HDT_ENABLE_CUDA); no GPU is needed to build it. HDT_BUILD_DIR overrides build/.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HDT_BUILD_DIR:-$root/build}"

# The CUDA toolkit installs outside PATH; let CMake find the compiler there.
if ! command -v nvcc >/dev/null && [[ -x /usr/local/cuda/bin/nvcc ]]; then
  export PATH="/usr/local/cuda/bin:$PATH"
fi

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build "$build" --parallel "$(nproc)"
