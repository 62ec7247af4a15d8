#!/usr/bin/env bash
# Everything CI checks: install what is missing, build, run every ctest test
# (GoogleTest suites, CLI cases, and the ParaView/pvpython tests when built).
#   bash scripts/test.sh [extra cmake arguments]
# Then the sanitizer runs: the unit tests and CLI cases under ASan + UBSan
# (scripts/sanitize.sh) and each libFuzzer harness for HDT_FUZZ_SECONDS
# (default 60, scripts/fuzz.sh); HDT_SKIP_SANITIZERS=1 leaves both out.
# Exits non-zero when anything fails.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${HDT_BUILD_DIR:-$root/build}"

bash "$root/scripts/install-deps.sh"
bash "$root/scripts/build.sh" "$@"

cd "$build"
ctest_args=(--output-on-failure -j2 --no-tests=error)
# Rendering tests need an X display; on a headless machine give the whole run one.
# -noreset: by default Xvfb resets whenever its last client disconnects and
# refuses the clients that connect meanwhile ("bad X server connection"); with
# pvpython processes coming and going that race failed pvbatch.render_demo in
# CI, and two loops of xdpyinfo lose 52 of 600 connections without it, 0 with.
if [[ -z ${DISPLAY:-} ]] && command -v xvfb-run >/dev/null; then
  xvfb-run --auto-servernum --server-args="-screen 0 1280x1024x24 -noreset" ctest "${ctest_args[@]}"
else
  ctest "${ctest_args[@]}"
fi

if [[ ${HDT_SKIP_SANITIZERS:-0} != 1 ]]; then
  bash "$root/scripts/sanitize.sh"
  bash "$root/scripts/fuzz.sh" "${HDT_FUZZ_SECONDS:-60}"
fi
