#!/usr/bin/env bash
# The main job, from a fresh Debian 12 machine: install what is missing, build,
# then voxelize the built-in trefoil knot
#   at 1024^3 -> out/demo.hdt        (the HDT volume; prints the statistics table)
#   at  256^3 -> out/demo-256.nrrd   (dense uint8 states, for any volume viewer)
# and renders out/demo.hdt with the ParaView plugin under pvbatch -> out/demo.png
#   bash scripts/demo.sh [extra cmake arguments]
# HDT_DEMO_MESH picks another mesh (a file path or builtin:NAME), HDT_OUT_DIR
# another output folder.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HDT_BUILD_DIR:-$root/build}"
out="${HDT_OUT_DIR:-$root/out}"
mesh="${HDT_DEMO_MESH:-builtin:knot}"
voxelize="$build/apps/hdt-voxelize"

bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh" "$@"
mkdir -p "$out"

echo
echo "== $mesh at 1024^3 -> $out/demo.hdt"
"$voxelize" "$mesh" --resolution 1024 -o "$out/demo.hdt"

echo
echo "== $mesh at 256^3 -> $out/demo-256.nrrd"
"$voxelize" "$mesh" --resolution 256 --dense "$out/demo-256.nrrd" --quiet >/dev/null
echo "wrote $out/demo-256.nrrd"

# The ParaView side of the main job: pvbatch opens out/demo.hdt with the
# plugin's reader and renders its voxel surface (the reader's second output,
# extracted from the HDT; depth 5, cells of 2 voxels, looks like full depth at
# this size and draws a quarter of the quads; --cutaway would show the hyper
# tree grid cut open instead, slower to draw: bench/results/voxel-surface.md).
# Debian's ParaView renders through X only, hence xvfb-run; -noreset
# because pvbatch probes OpenGL with a window of its own first, and a server
# that resets when its last client leaves refuses connections meanwhile.
plugin="$build/lib/paraview-5.11/plugins/HDTVoxelizer/HDTVoxelizer.so"
if [[ -f $plugin ]] && command -v pvbatch >/dev/null; then
  echo
  echo "== rendering $out/demo.hdt -> $out/demo.png"
  display=()
  [[ -z ${DISPLAY:-} ]] && display=(xvfb-run -a --server-args="-screen 0 1280x1024x24 -noreset")
  "${display[@]}" pvbatch "$root/scripts/render_demo.py" --hdt "$out/demo.hdt" \
    --png "$out/demo.png" --max-depth 5 --plugin "$plugin"
else
  echo "(ParaView plugin not built: skipping the pvbatch render)"
fi
