# Sourced by the device-call scripts (bench/gpu/*-s18/, *-s19/) from the
# repository root, with carry [".devdeps"]: the device machine's environment
# for the binaries carried in .devcarry/NAME.tar.xz (untracked), unpacked to
# /tmp; T0 starts the call's clock.
#   . bench/gpu/call-setup.sh NAME
set -u
ROOT=$(pwd)
export LD_LIBRARY_PATH=$ROOT/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64 HDT_MESHES_DIR=$ROOT/.devdeps/meshes
export PATH=/usr/local/cuda/bin:$PATH
T0=$SECONDS
tar xJf ".devcarry/$1.tar.xz" -C /tmp || { echo "unpack failed"; exit 1; }
nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
date -u

# deviceTests BINARY FILTER [MEMCHECK_SECONDS] [TEST_SECONDS]: every test of
# the device test binary, beside memcheck on those matching FILTER, with a
# summary of both (tests.log, memcheck.log in $OUT).
deviceTests() {
  timeout "${3:-90}" compute-sanitizer --tool memcheck --error-exitcode 9 "$1" --gtest_filter="$2" > $OUT/memcheck.log 2>&1 &
  local mc=$!
  timeout "${4:-150}" "$1" > $OUT/tests.log 2>&1; echo "tests rc=$? at $((SECONDS-T0)) s"
  wait $mc; echo "memcheck rc=$? at $((SECONDS-T0)) s"
  echo "tests: $(grep -E '^\[  (PASSED|FAILED) ' $OUT/tests.log | tr '\n' ' ') OK lines $(grep -c '^\[       OK \]' $OUT/tests.log), SKIPPED $(grep -c '^\[  SKIPPED \] .*(' $OUT/tests.log)"
  grep -E "^\[  FAILED  \] .*\(" $OUT/tests.log | head -10
  echo "memcheck: $(grep -E 'ERROR SUMMARY|^\[  (PASSED|FAILED) ' $OUT/memcheck.log | tr '\n' ' ')"
}
