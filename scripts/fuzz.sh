#!/usr/bin/env bash
# Builds the libFuzzer harnesses (tests/fuzz) with clang, ASan and UBSan, writes
# their seed corpora and fuzzes each one for SECONDS (default 60).
#   bash scripts/fuzz.sh [SECONDS]       # CI runs 60; a long run: 3600 or more
# Corpora grow in $HDT_FUZZ_DIR (default build-fuzz/corpus) and are kept between
# runs; findings (crash-*, leak-*, timeout-*) land in build-fuzz/findings/.
# Exits non-zero when a harness finds something.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
seconds="${1:-60}"
build="${HDT_FUZZ_BUILD_DIR:-$root/build-fuzz}"
corpus="${HDT_FUZZ_DIR:-$build/corpus}"
sanitizers="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"

command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ is missing (Debian: clang, libclang-rt-14-dev)" >&2; exit 1; }
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ \
  -DCMAKE_CXX_FLAGS="$sanitizers -fsanitize=fuzzer-no-link" \
  -DCMAKE_EXE_LINKER_FLAGS="$sanitizers" -DCMAKE_SHARED_LINKER_FLAGS="$sanitizers" \
  -DHDT_ENABLE_CUDA=OFF -DHDT_BUILD_PARAVIEW=OFF -DHDT_BUILD_FUZZERS=ON >/dev/null
ninja -C "$build" -j"$(nproc)" hdt_fuzz_seeds fuzz_hdt_reader fuzz_mesh_reader fuzz_pipeline

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}"
export LSAN_OPTIONS="suppressions=$root/tests/fuzz/lsan.supp"
mkdir -p "$corpus" "$build/findings"
"$build/tests/fuzz/hdt_fuzz_seeds" "$build/seeds" # fresh seeds each run, from the tests' shapes

status=0
for harness in hdt_reader mesh_reader pipeline; do
  mkdir -p "$corpus/$harness"
  echo "== fuzz_$harness: ${seconds} s" >&2
  # -rss_limit_mb: the reader may legitimately decode what a valid file states.
  "$build/tests/fuzz/fuzz_$harness" "$corpus/$harness" "$build/seeds/$harness" \
    -max_total_time="$seconds" -rss_limit_mb=4096 -max_len=65536 -timeout=30 \
    -artifact_prefix="$build/findings/$harness-" -print_final_stats=1 2>"$build/fuzz_$harness.log" \
    || { status=1; tail -40 "$build/fuzz_$harness.log" >&2; }
  grep -E "^stat::number_of_executed_units|^Done" "$build/fuzz_$harness.log" >&2 || true
done
exit $status
