#!/bin/sh
# ctest driver of pvbatch.render_demo: the README's pipeline at a small size.
#   render_demo_test.sh HDT_VOXELIZE PVBATCH RENDER_DEMO_PY PLUGIN TMPDIR
# hdt-voxelize writes the built-in knot as .hdt, scripts/render_demo.py renders
# it with a cut-away, and check_image.py makes sure the image shows both voxel
# states. Debian's ParaView renders through X: without a DISPLAY the render
# runs under xvfb-run (with_display.sh).
set -eu
cli=$1 pvbatch=$2 script=$3 plugin=$4 tmp=$5
mkdir -p "$tmp"
rm -f "$tmp/knot.hdt" "$tmp/knot.png"

"$cli" builtin:knot --resolution 128 --leaf-size 8 --quiet -o "$tmp/knot.hdt" >/dev/null

sh "$(dirname "$0")/with_display.sh" "$pvbatch" "$script" --hdt "$tmp/knot.hdt" \
  --png "$tmp/knot.png" --size 640x400 --cutaway --plugin "$plugin"
"$pvbatch" "$(dirname "$0")/check_image.py" "$tmp/knot.png"
echo "render_demo_test: ok"
