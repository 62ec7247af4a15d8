#!/usr/bin/env bash
# same-device-code.sh REV [ARCH]: does the working tree compile to the same GPU
# machine code as git revision REV?
#
# GPU time is scarce: when a change touches only host code, comments or the
# shared headers' host-visible parts, the GPU tests and sanitizer runs of REV
# still hold for the device side if every kernel compiles to the same bytes.
# This compiles each cuda/src/*.cu to a cubin (sm_ARCH, default 90, with the
# driver's code-generation flags but without -lineinfo, whose line tables move
# with any edit) for REV and for the working tree, from the same relative
# paths (nvcc's names for anonymous namespaces hash the source path), and
# compares the files. Needs only nvcc, no GPU. Exit 0: identical; 1: differs.
# The host side (including the CPU builder both drivers share) is what the CPU
# tests check; this says nothing about it.
set -euo pipefail
rev=${1:?usage: same-device-code.sh REV [ARCH]}
arch=${2:-90}
root=$(git rev-parse --show-toplevel)
nvcc=${NVCC:-$(command -v nvcc || echo /usr/local/cuda/bin/nvcc)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# The same flags as cuda/CMakeLists.txt gives the kernels (Release).
flags=(-O3 -DNDEBUG -arch=sm_$arch --fmad=false -Xcompiler=-ffp-contract=off
       --expt-relaxed-constexpr -std=c++17 -Icuda/include -Icuda/src -Icore/include)

compile() { # SOURCE_TREE OUT_DIR
  mkdir -p "$2"
  (cd "$1" && for cu in cuda/src/*.cu; do
     "$nvcc" "${flags[@]}" -cubin "$cu" -o "$2/$(basename "$cu" .cu).cubin" &
   done; wait)
}

# Both trees at the same path, one after the other.
mkdir -p "$work/src"
git -C "$root" archive "$rev" core cuda | tar -x -C "$work/src"
compile "$work/src" "$work/rev"
rm -rf "$work/src"/*
(cd "$root" && tar -c core cuda) | tar -x -C "$work/src"
compile "$work/src" "$work/tree"

status=0
for f in "$work"/tree/*.cubin; do
  b=$(basename "$f")
  if [[ ! -f $work/rev/$b ]]; then echo "new:       $b"; status=1
  elif cmp -s "$f" "$work/rev/$b"; then echo "identical: $b"
  else echo "differs:   $b"; status=1; fi
done
for f in "$work"/rev/*.cubin; do
  [[ -f $work/tree/$(basename "$f") ]] || { echo "removed:   $(basename "$f")"; status=1; }
done
exit $status
