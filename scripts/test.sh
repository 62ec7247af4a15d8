#!/usr/bin/env bash
# Everything CI checks: install what is missing, build, run every ctest test
# (GoogleTest suites, CLI cases, and the ParaView/pvpython tests when built).
#   bash scripts/test.sh [extra cmake arguments]
# Exits non-zero when anything fails.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HDT_BUILD_DIR:-$root/build}"

bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh" "$@"

cd "$build"
ctest_args=(--output-on-failure -j2 --no-tests=error)
# Rendering tests need an X display; on a headless machine give the whole run one.
if [[ -z ${DISPLAY:-} ]] && command -v xvfb-run >/dev/null; then
  xvfb-run --auto-servernum --server-args="-screen 0 1280x1024x24" ctest "${ctest_args[@]}"
else
  ctest "${ctest_args[@]}"
fi
