#!/usr/bin/env bash
# Everything the CUDA driver needs a GPU for, in one script, for the GPU
# machine of the `run` tool (see bench/gpu/README.md). Run from the
# repository root with .devdeps/ carried along:
#
#   bench/gpu/device-run.sh STEP...
#     info      GPU, driver, toolkit
#     build     configure + build (arch 90) in build-device/, unless
#               .devdeps/bin holds binaries built elsewhere for this machine
#     buildsrc  configure + build from source even then (checks the build)
#     quick     a few GPU-vs-CPU tests
#     tests     all CUDA tests (hdt_cuda_tests; TESTS_FILTER narrows them)
#     sanitize  compute-sanitizer memcheck on every test, initcheck and synccheck on a reduced set
#     memcheck  memcheck on a subset (MEMCHECK_FILTER, MEMCHECK_TIMEOUT)
#     racecheck racecheck on the generated shapes, dense clusters, driver tests and meshes at 1024
#               (RACECHECK_FILTER: another gtest filter)
#     vtktests  the VTK filter's tests (hdt_vtk_tests, CUDA path included) from the carried
#               tarball .devdeps/vtk-tests.tar.xz (bin/ and lib/: see bench/gpu/README.md)
#     bench     hdt_gpu_bench over all meshes, 1K..32K, surface and solid,
#               and the >= 1M-triangle 32768^3 run
#     profile   ncu on one 8192^3 build (profile2: a second mesh; sass: instruction mix)
#     cli       hdt-voxelize ... --backend cuda -o, the whole process's wall time (CLI_RUNS)
#     e2e       mesh file to .hdt file, every step timed, one process a run
#               (hdt_e2e_bench; E2E_MESHES, E2E_RES, E2E_MODES, E2E_TIMEOUT)
#     multigpu  hdt-voxelize-mpi, one rank per GPU, K = 1..8, files compared (MULTIGPU_*)
#     winding   the winding-number inside test: CPU == CUDA tests (*CudaWinding*), then
#               hdt_gpu_bench solid (parity) vs winding on the open meshes at 128 and 256
#               (WINDING_MESHES, WINDING_RES, WINDING_TIMEOUT)
#     labelbin  bench/run_label_bench.py with $BIN/hdt-voxelize (a CLI built for this machine
#               and carried in $BIN: no MPI bundle; LABELS_RES, LABELS_REPEAT, LABELS_TIMEOUT)
#     minibench, variant: quicker subsets used while tuning
# Steps read a few environment variables (BENCH_*, PROFILE_*, MINIBENCH_*, TESTS_TIMEOUT).
#
# Logs and results go to $OUT (the run tool brings back at most 8 files).
# .devdeps/ holds what the bare machine lacks: googletest sources, oneTBB,
# zlib and zstd headers and libraries, and the shared meshes as binary PLY
# (the machine's build has no assimp for OBJ and ASCII STL).
set -u -o pipefail
ROOT=$(pwd)
DEPS=$ROOT/.devdeps
OUT=${OUT:-$ROOT/device-out}
mkdir -p "$OUT"
export LD_LIBRARY_PATH=$DEPS/lib/x86_64-linux-gnu:/usr/local/cuda/lib64:${LD_LIBRARY_PATH:-}
export HDT_MESHES_DIR=$DEPS/meshes
export PATH=/usr/local/cuda/bin:$PATH
# DEVICE_BIN: a folder of binaries built elsewhere for this machine (a helper's staged build)
if [ -n "${DEVICE_BIN:-}" ]; then BIN=$DEVICE_BIN; elif [ -x "$DEPS/bin/hdt_cuda_tests" ]; then BIN=$DEPS/bin; else BIN=$ROOT/build-device/bin; fi
TESTS=$BIN/hdt_cuda_tests
BENCH=$BIN/hdt_gpu_bench
E2E=$BIN/hdt_e2e_bench
SUMMARY=$OUT/summary.txt

say() { echo "== $*" | tee -a "$SUMMARY"; }

step_info() {
  { nvidia-smi; nvcc --version; cmake --version | head -1; nproc; free -g; date -u; } > "$OUT/info.txt" 2>&1
  say "info: $(nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader)"
}

step_build() {
  if [ "$BIN" = "$DEPS/bin" ]; then say "build: using prebuilt binaries in .devdeps/bin"; return 0; fi
  step_buildsrc
}

step_buildsrc() {
  local t0=$SECONDS
  {
    cmake -S "$ROOT" -B "$ROOT/build-device" -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DHDT_BUILD_PARAVIEW=OFF -DCMAKE_CUDA_ARCHITECTURES=90-real \
      -DCMAKE_PREFIX_PATH="$DEPS" -DTBB_DIR="$DEPS/lib/x86_64-linux-gnu/cmake/TBB" \
      -DZLIB_ROOT="$DEPS" -DHDT_GTEST_SOURCE_DIR="$DEPS/googletest" &&
      ninja -C "$ROOT/build-device" hdt_cuda_tests hdt_gpu_bench hdt_e2e_bench &&
      mkdir -p "$ROOT/build-device/bin" &&
      cp "$ROOT/build-device/tests/hdt_cuda_tests" "$ROOT/build-device/bench/gpu/hdt_gpu_bench" \
        "$ROOT/build-device/bench/gpu/hdt_e2e_bench" "$ROOT/build-device/bin/"
  } > "$OUT/build.log" 2>&1
  local rc=$?
  say "build: rc=$rc in $((SECONDS - t0)) s"
  [ $rc -eq 0 ] || { tail -40 "$OUT/build.log"; exit 1; }
  # The later steps use what was just built, not binaries left in .devdeps/bin.
  BIN=$ROOT/build-device/bin TESTS=$ROOT/build-device/bin/hdt_cuda_tests BENCH=$ROOT/build-device/bin/hdt_gpu_bench
  E2E=$ROOT/build-device/bin/hdt_e2e_bench
}

run_tests() { # name filter timeout
  local t0=$SECONDS
  timeout "$3" "$TESTS" --gtest_filter="$2" --gtest_color=no > "$OUT/$1.log" 2>&1
  local rc=$?
  say "$1: rc=$rc in $((SECONDS - t0)) s: $(grep -E '^\[  (PASSED|FAILED|SKIPPED) ' "$OUT/$1.log" | tr '\n' ' ')"
  grep -E '^\[  FAILED  \]|Failure|error' "$OUT/$1.log" | head -20 | tee -a "$SUMMARY"
}

step_minibench() { # MINIBENCH_BIN (default the bench), MINIBENCH_MESHES, MINIBENCH_RES, MINIBENCH_TAG
  local t0=$SECONDS tag=${MINIBENCH_TAG:-minibench} args=()
  for m in ${MINIBENCH_MESHES:-stanford-dragon-100k.ply nefertiti.ply}; do args+=(--mesh "$m"); done
  timeout 200 "${MINIBENCH_BIN:-$BENCH}" --meshes "$DEPS/meshes" "${args[@]}" --res "${MINIBENCH_RES:-1024,8192}" \
    --runs 3 --out "$OUT/$tag.jsonl" > "$OUT/$tag.log" 2>&1
  say "$tag: rc=$? in $((SECONDS - t0)) s"
  cat "$OUT/$tag.log" | tee -a "$SUMMARY"
}

step_e2e() { # E2E_RUNS: "MESH:SUBDIVIDE:N:MODE[:FLAGS] ..." (meshes in .devdeps/meshes; FLAGS:
  # hdt_e2e_bench options without their dashes, comma-separated, a value after '=', e.g.
  # write-breakdown,prepare-repeat=5), in order until E2E_END
  # (seconds since the script started) or E2E_TIMEOUT seconds from now
  local t0=$SECONDS out=$OUT/e2e-runs.jsonl deadline=${E2E_END:-$((SECONDS + ${E2E_TIMEOUT:-300}))}
  local runs=${E2E_RUNS:-}
  if [ -z "$runs" ]; then
    for m in stanford-dragon-100k.ply nefertiti.ply cycloidal-drive.ply; do
      for n in 1024 4096 8192 16384 32768 65536; do runs+=" $m:0:$n:surface $m:0:$n:solid"; done
    done
  fi
  for spec in $runs; do
    IFS=: read -r m k n mode flag <<< "$spec"
    local left=$((deadline - SECONDS))
    [ $left -gt 5 ] || { say "e2e: out of time before $spec"; break; }
    local extra=() f
    for f in ${flag//,/ }; do extra+=("--${f%%=*}"); [[ $f == *=* ]] && extra+=("${f#*=}"); done
    timeout $left "$E2E" "$DEPS/meshes/$m" --subdivide "$k" --res "$n" --mode "$mode" --backend cuda \
      --hdt /tmp/e2e.hdt --out "$out" "${extra[@]}" >> "$OUT/e2e.log" 2>&1 || say "e2e: rc=$? for $spec"
    rm -f /tmp/e2e.hdt
  done
  # cold start: the first build of a process without and with hdt::prepareCuda, against a warm one
  for flag in --cold "" --cold ""; do
    "$E2E" "$DEPS/meshes/stanford-dragon-100k.ply" --res 2048 --mode surface --backend cuda $flag --warm-check \
      --hdt /tmp/e2e.hdt --out "$OUT/e2e-cold.jsonl" >> "$OUT/e2e.log" 2>&1
  done
  say "e2e: $(wc -l < "$out") runs in $((SECONDS - t0)) s"
  python3 - "$out" "$OUT/e2e-cold.jsonl" <<'PY' | tee -a "$SUMMARY"
import json, sys
for f in sys.argv[1:]:
    for l in open(f):
        r = json.loads(l)
        if 'error' in r: print(r['mesh'], r['resolution'], 'surface' if r['surface_only'] else 'solid', 'error:', r['error'][:100]); continue
        print(f"{r['mesh'][:22]:22} {r['resolution']:6} {'surface' if r['surface_only'] else 'solid':7} read {r['read_ms']:8.1f} prep {r['prepare_ms']:7.1f} "
              f"wait {r['warm_up_wait_ms']:6.1f} phases {r['build_phases_ms']:7.2f} build {r['build_wall_ms']:8.1f} copy {r['copy_back_ms']:8.1f} "
              f"({r['copy_back_gb_per_s']:5.1f} GB/s) write {r['write_ms']:8.1f} wall {r['wall_ms']:8.1f} host {r['peak_host_bytes']/2**30:6.2f} GiB "
              f"dev {r['peak_device_bytes']/2**30:6.2f} GiB chunks {r['chunks']}" + (f" serialize {r['serialize_ms']:.1f} one-frame {r.get('serialize_one_frame_ms', -1):.1f} level1 {r.get('serialize_level1_ms', -1):.1f} ({r.get('serialize_level1_bytes', 0)} vs {r.get('serialize_bytes', 0)} B) raw {r['write_raw_ms']:.1f}" if 'serialize_ms' in r else '') + (f" warm {r['warm_build_phases_ms']:.2f} cold={r['cold']}" if 'warm_build_phases_ms' in r else '') + (f" prepare parts {r['prepare_parts_ms']} best of {r['prepare_repeat']} {r['prepare_best_ms']:.1f} {r['prepare_best_parts_ms']}" if 'prepare_best_ms' in r else ''))
PY
}

step_variant() { # the same minibench with .devdeps/bin/hdt_gpu_bench_$VARIANT
  MINIBENCH_BIN=$BIN/hdt_gpu_bench_${VARIANT:-mb8} MINIBENCH_TAG=variant step_minibench
}

step_quick() {
  run_tests quick '*CudaShapes*/sphere_*:*CudaShapes*/open_hemisphere_*:*CudaShapes*/grid_aligned_box_R16*:CudaDriver.*' 300
}

step_tests() { run_tests tests "${TESTS_FILTER:-*}" "${TESTS_TIMEOUT:-540}"; }

step_cli() { # CLI_RUNS: "MESH:N[:surface] ..." hdt-voxelize MESH --resolution N --backend cuda -o, wall
  # time of the whole process (built from source: buildsrc first, or DEVICE_BIN), CLI_REPEAT times each
  # (default 2; the later ones find the file cache warm); the --json reports with the wall time in
  # $OUT/cli-runs.jsonl
  local cli=$ROOT/build-device/apps/hdt-voxelize t0=$SECONDS
  if [ -x "$BIN/hdt-voxelize" ]; then cli=$BIN/hdt-voxelize
  else ninja -C "$ROOT/build-device" hdt-voxelize >> "$OUT/build.log" 2>&1 || { say "cli: build failed"; return; }; fi
  for spec in ${CLI_RUNS:-stanford-dragon-100k.ply:8192 nefertiti.ply:8192}; do
    IFS=: read -r m n mode <<< "$spec"
    for k in $(seq "${CLI_REPEAT:-2}"); do
      local s=$(date +%s.%N)
      "$cli" "$DEPS/meshes/$m" --resolution "$n" --backend cuda ${mode:+--surface-only} -o /tmp/cli.hdt --json \
        > /tmp/cli-last.json 2>> /tmp/cli.log || say "cli: rc=$? for $spec"
      local e=$(date +%s.%N) wall
      wall=$(python3 -c "print(round(($e - $s) * 1000))")
      python3 -c "import json, sys; d = json.load(open('/tmp/cli-last.json')); d['process_wall_ms'] = $wall; d['date'] = '$(date -u +%FT%TZ)'; print(json.dumps(d))" >> "$OUT/cli-runs.jsonl" 2>/dev/null
      say "cli: $m $n ${mode:-solid} wall $wall ms, file $(stat -c %s /tmp/cli.hdt) bytes, $(python3 -c "import json; d = json.load(open('/tmp/cli-last.json')); print('io_ms', d['io_ms'], 'phases_ms', d['time_ms']['total'], 'peak_host_GiB', round(d['peak_host_bytes'] / 2**30, 2))" 2>&1)"
      rm -f /tmp/cli.hdt
    done
  done
  say "cli: done in $((SECONDS - t0)) s"
}

step_copy() { # hdt_copy_bench: copy-back variants into fresh pageable memory (COPY_MB, COPY_REPS), then
  # the process floor: a context alone, with 64 MiB pinned, 1 GiB allocated, 1 GiB kept in the pool
  local t0=$SECONDS
  timeout "${COPY_TIMEOUT:-200}" "$BIN/hdt_copy_bench" --mb "${COPY_MB:-400,3600}" --reps "${COPY_REPS:-3}" \
    --out "$OUT/copy-runs.jsonl" > "$OUT/copy.log" 2>&1
  say "copy: rc=$? in $((SECONDS - t0)) s"
  python3 - "$OUT/copy-runs.jsonl" <<'PY' | tee -a "$SUMMARY"
import json, sys, collections
runs = collections.defaultdict(list)
for l in open(sys.argv[1]):
    r = json.loads(l); runs[(r['variant'], r['bytes'])].append(r['gb_per_s'])
for (v, b), g in runs.items(): print(f"{v:26} {b/1e6:6.0f} MB  GB/s " + " ".join(f"{x:5.1f}" for x in g))
PY
  for how in ${COPY_PROBES:-none ctx reset pin pool all none ctx reset pin pool all}; do
    local s=$(date +%s.%N) line; line=$("$BIN/hdt_copy_bench" --probe $how); local e=$(date +%s.%N)
    say "$line, process wall $(python3 -c "print(round(($e - $s) * 1000))") ms"
  done
}

step_sanitize() { # memcheck on every CUDA test; initcheck and synccheck on a reduced set
  local t0=$SECONDS
  timeout 300 compute-sanitizer --tool memcheck --error-exitcode 9 "$TESTS" > "$OUT/memcheck.log" 2>&1
  say "memcheck: rc=$? in $((SECONDS - t0)) s: $(grep -E 'ERROR SUMMARY|^\[  (PASSED|FAILED) ' "$OUT/memcheck.log" | tr '\n' ' ')"
  local filter='*CudaDense*:*CudaShapes*/two_bodies_R16_L16_*:*CudaShapes*/open_hemisphere_R8_L32_*:*CudaShapes*/grid_aligned_box_R16_L8_*:*CudaChunked*/open_hemisphere*'
  for tool in initcheck synccheck; do
    t0=$SECONDS
    timeout 150 compute-sanitizer --tool $tool --error-exitcode 9 "$TESTS" --gtest_filter="$filter" > "$OUT/$tool.log" 2>&1
    say "$tool: rc=$? in $((SECONDS - t0)) s: $(grep -E 'SUMMARY|^\[  (PASSED|FAILED) ' "$OUT/$tool.log" | tr '\n' ' ')"
  done
}

step_memcheck() { # memcheck on a subset (MEMCHECK_FILTER), MEMCHECK_TIMEOUT
  local t0=$SECONDS
  timeout "${MEMCHECK_TIMEOUT:-240}" compute-sanitizer --tool memcheck --error-exitcode 9 "$TESTS" \
    --gtest_filter="${MEMCHECK_FILTER:-CudaDriver.*:*CudaChunked*}" > "$OUT/memcheck.log" 2>&1
  say "memcheck ${MEMCHECK_FILTER:-}: rc=$? in $((SECONDS - t0)) s: $(grep -E 'ERROR SUMMARY|^\[  (PASSED|FAILED) ' "$OUT/memcheck.log" | tr '\n' ' ')"
}

step_racecheck() { # shared-memory hazards; every shared access tracked (~100x slower): all generated
  # shapes, the dense clusters, the driver tests and the shared meshes at 1024 (about 4 minutes on an
  # H100); the chunked tests and the larger meshes do not fit one 10-minute call
  local t0=$SECONDS
  timeout 540 compute-sanitizer --tool racecheck --racecheck-report hazard --error-exitcode 9 "$TESTS" \
    --gtest_filter="${RACECHECK_FILTER:-*CudaShapes*:*CudaDense*:CudaDriver.*:*CudaSharedMeshes*N1024*}" > "$OUT/racecheck.log" 2>&1
  say "racecheck: rc=$? in $((SECONDS - t0)) s: $(grep -E 'SUMMARY|^\[  (PASSED|FAILED) ' "$OUT/racecheck.log" | tr '\n' ' ')"
}

step_vtktests() { # hdt_vtk_tests built on the development machine, with its shared libraries
  local t0=$SECONDS tarball=${VTK_TESTS_TARBALL:-$DEPS/vtk-tests.tar.xz} dir=/tmp/hdt-vtk-tests
  if [ ! -f "$tarball" ]; then say "vtktests: no $tarball (see bench/gpu/README.md)"; return 0; fi
  rm -rf "$dir" && mkdir -p "$dir" && tar -xJf "$tarball" -C "$dir" || { say "vtktests: cannot unpack $tarball"; return 0; }
  # The tarball's lib/ first: the binary's own closure, without libc, libm, libstdc++ and libgcc
  # (the machine's own). libcuda comes from the driver, as for every other step.
  if LD_LIBRARY_PATH=$dir/lib:$LD_LIBRARY_PATH ldd "$dir/bin/hdt_vtk_tests" | grep -q 'not found'; then
    LD_LIBRARY_PATH=$dir/lib:$LD_LIBRARY_PATH ldd "$dir/bin/hdt_vtk_tests" | grep 'not found' | tee -a "$SUMMARY"
  fi
  LD_LIBRARY_PATH=$dir/lib:$LD_LIBRARY_PATH timeout "${VTK_TESTS_TIMEOUT:-300}" "$dir/bin/hdt_vtk_tests" \
    --gtest_color=no > "$OUT/vtktests.log" 2>&1
  say "vtktests: rc=$? in $((SECONDS - t0)) s: $(grep -E '^\[  (PASSED|FAILED|SKIPPED) ' "$OUT/vtktests.log" | tr '\n' ' ')"
  grep -E '^\[  FAILED  \]|Failure' "$OUT/vtktests.log" | head -20 | tee -a "$SUMMARY"
}

step_bench() { # BENCH_MESHES (default all), BENCH_RES, BENCH_MODES, BENCH_RUNS, BENCH_TIMEOUT, BENCH_TAG; BIG=1 adds the 1.6M-triangle run
  local t0=$SECONDS tag=${BENCH_TAG:-gpu-runs} args=()
  for m in ${BENCH_MESHES:-}; do args+=(--mesh "$m"); done
  timeout "${BENCH_TIMEOUT:-420}" "$BENCH" --meshes "$DEPS/meshes" "${args[@]}" --res "${BENCH_RES:-1024,2048,4096,8192,16384,32768}" \
    --modes "${BENCH_MODES:-surface,solid}" --runs "${BENCH_RUNS:-5}" --out "$OUT/$tag.jsonl" > "$OUT/$tag.log" 2>&1
  say "bench $tag: rc=$? in $((SECONDS - t0)) s"
  if [ "${BIG:-0}" = 1 ]; then
    t0=$SECONDS
    timeout 120 "$BENCH" --meshes "$DEPS/meshes" --mesh stanford-dragon-100k.ply --subdivide 2 --res 32768 \
      --modes surface,solid --runs 3 --out "$OUT/$tag.jsonl" >> "$OUT/$tag.log" 2>&1
    say "bench 1.6M triangles at 32768: rc=$? in $((SECONDS - t0)) s"
  fi
  cat "$OUT/$tag.log"
}

step_profile() { # PROFILE_MESH, PROFILE_RES, PROFILE_MODE, PROFILE_KERNELS, PROFILE_COUNT, PROFILE_TAG
  local t0=$SECONDS tag=${PROFILE_TAG:-profile}
  timeout "${PROFILE_TIMEOUT:-300}" ncu --set full -k "regex:${PROFILE_KERNELS:-leafSurface|childTest|leafInside|leafCrossings|lineSuffix|uniform|rootCount|Onesweep}" \
    -c "${PROFILE_COUNT:-24}" -o /tmp/$tag -f "$BENCH" --meshes "$DEPS/meshes" --mesh "${PROFILE_MESH:-stanford-dragon-100k.ply}" \
    --res "${PROFILE_RES:-8192}" --modes "${PROFILE_MODE:-solid}" --runs 1 --out /tmp/profile-runs.jsonl > "$OUT/$tag.log" 2>&1
  say "$tag: rc=$? in $((SECONDS - t0)) s"
  ncu --import /tmp/$tag.ncu-rep --page details > "$OUT/$tag-details.txt" 2>&1
  ncu --import /tmp/$tag.ncu-rep --print-summary per-kernel >> "$OUT/$tag.log" 2>&1
}

step_profile2() { # a second mesh in the same call
  PROFILE_MESH=${PROFILE2_MESH:-ogre.ply} PROFILE_TAG=profile2 step_profile
}

step_kerneltimes() { # every kernel of one build with its duration (ncu, one metric; base clocks unless NCU_CLOCKS=none)
  local t0=$SECONDS
  timeout 300 ncu ${NCU_CLOCKS:+--clock-control $NCU_CLOCKS} --metrics gpu__time_duration.sum -c "${PROFILE_COUNT:-400}" --csv "$BENCH" --meshes "$DEPS/meshes" \
    --mesh "${PROFILE_MESH:-cycloidal-drive.ply}" --res "${PROFILE_RES:-8192}" --modes "${PROFILE_MODE:-solid}" --runs 1 \
    --out /tmp/kt-runs.jsonl > /tmp/kt.csv 2> "$OUT/kerneltimes.err"
  say "kerneltimes: rc=$? in $((SECONDS - t0)) s"
  python3 - /tmp/kt.csv > "$OUT/kerneltimes.txt" <<'PY'
import csv, sys, collections
rows = [r for r in csv.reader(l for l in open(sys.argv[1]) if l.startswith('"'))]
head = rows[0]; k = head.index('Kernel Name'); v = head.index('Metric Value'); u = head.index('Metric Unit')
tot = collections.defaultdict(float); cnt = collections.Counter()
for r in rows[1:]:
    scale = {'nsecond': 1e-6, 'ns': 1e-6, 'usecond': 1e-3, 'us': 1e-3, 'msecond': 1.0, 'ms': 1.0}.get(r[u], 1.0)
    name = r[k].split('(')[0][:90]; tot[name] += float(r[v].replace(',', '')) * scale; cnt[name] += 1
builds = max([c for n, c in cnt.items() if 'leafKernel' in n] or [1])  # one T3 launch a build
print(f"per build, over {builds} builds (warm-up included)")
for name, t in sorted(tot.items(), key=lambda x: -x[1]): print(f"{t / builds:9.3f} ms {cnt[name] / builds:5.1f}x  {name}")
print(f"{sum(tot.values()) / builds:9.3f} ms total")
PY
  head -30 "$OUT/kerneltimes.txt" | tee -a "$SUMMARY"
}

step_hotspots() { # instructions executed per CUDA source line of the leaf kernels (needs -lineinfo binaries)
  local t0=$SECONDS
  timeout 400 ncu --section SourceCounters --section WarpStateStats --section LaunchStats --section Occupancy \
    -k "regex:${PROFILE_KERNELS:-leafSurface|leafCrossings}" -c "${PROFILE_COUNT:-2}" -o /tmp/hot -f "$BENCH" \
    --meshes "$DEPS/meshes" --mesh "${PROFILE_MESH:-cycloidal-drive.ply}" --res "${PROFILE_RES:-8192}" \
    --modes "${PROFILE_MODE:-solid}" --runs 1 --out /tmp/hot-runs.jsonl > "$OUT/hotspots.log" 2>&1
  say "hotspots: rc=$? in $((SECONDS - t0)) s"
  ncu --import /tmp/hot.ncu-rep --page details >> "$OUT/hotspots.log" 2>&1
  ncu --import /tmp/hot.ncu-rep --page source --csv --print-source cuda > /tmp/hot-src.csv 2>> "$OUT/hotspots.log"
  cp /tmp/hot-src.csv "$OUT/hotspots-source.csv"
  ncu --import /tmp/hot.ncu-rep --page source --csv --print-source sass > /tmp/hot-sass.csv 2>> "$OUT/hotspots.log"
  gzip -c /tmp/hot-sass.csv > "$OUT/hotspots-sass.csv.gz"
}

step_sass() { # the kernels' SASS instruction mix (cuobjdump is on the GPU machine only)
  cuobjdump -sass "$BENCH" > /tmp/sass.txt 2>&1
  python3 - /tmp/sass.txt > "$OUT/sass-mix.txt" <<'PY'
import re, sys, collections
cur=None; mix=collections.defaultdict(collections.Counter)
for line in open(sys.argv[1]):
    m=re.search(r'Function : (\S+)', line)
    if m: cur=m.group(1); continue
    m=re.match(r'\s+/\*[0-9a-f]{4}\*/\s+(@!?U?P\w+\s+)?([A-Z][A-Z0-9_.]+)', line)
    if m and cur: mix[cur][m.group(2).split('.')[0]]+=1
for f,c in mix.items():
    if any(k in f for k in ('leafSurface','leafCrossings','leafInside','childTest')):
        print(f[:120], sum(c.values())); print('   ', c.most_common(25))
PY
  say "sass: $(wc -l < "$OUT/sass-mix.txt") lines"
}

: > "$SUMMARY"
unpack_cli_bundle() { # .devdeps/mpi-runtime.tar.xz -> /tmp/hdt-mpi: Open MPI (a mirror of /usr under
  # one prefix, relocated by OPAL_PREFIX) and hdt-voxelize / hdt-voxelize-mpi built on the development
  # machine (CUDA and MPI on) with their libraries; see bench/gpu/README.md
  CLI_DIR=/tmp/hdt-mpi
  [ -x "$CLI_DIR/ompi/bin/hdt-voxelize" ] && return 0
  [ -f "$DEPS/mpi-runtime.tar.xz" ] || { say "no $DEPS/mpi-runtime.tar.xz"; return 1; }
  rm -rf "$CLI_DIR" && mkdir -p "$CLI_DIR/build/apps" && tar -xJf "$DEPS/mpi-runtime.tar.xz" -C "$CLI_DIR" &&
    ln -s "$CLI_DIR/ompi/bin/hdt-voxelize" "$CLI_DIR/ompi/bin/hdt-voxelize-mpi" "$CLI_DIR/build/apps/"
}

step_mpigpu() { # hdt-voxelize-mpi, 1-4 ranks sharing the GPU (issue 14): bench/gpu/mpi_gpu_bench.sh
  local t0=$SECONDS
  unpack_cli_bundle || return 0
  ( export OPAL_PREFIX=$CLI_DIR/ompi PATH=$CLI_DIR/ompi/bin:$PATH \
      LD_LIBRARY_PATH=$CLI_DIR/ompi/lib/x86_64-linux-gnu:$LD_LIBRARY_PATH OMPI_MCA_btl=self,vader TMPDIR=/tmp
    timeout "${MPIGPU_TIMEOUT:-300}" bash "$ROOT/bench/gpu/mpi_gpu_bench.sh" "$CLI_DIR/build" \
      "$DEPS/meshes/${MPIGPU_MESH:-stanford-dragon-100k.ply}" ${MPIGPU_RES:-2048 4096} ) > "$OUT/mpigpu.log" 2>&1
  say "mpigpu: rc=$? in $((SECONDS - t0)) s"
  tail -14 "$OUT/mpigpu.log" | tee -a "$SUMMARY"
  cp "$ROOT/bench/results/mpi-gpu-runs.jsonl" "$OUT/" 2>/dev/null || true
}

step_multigpu() { # one rank per GPU, K = 1, 2, 4, 8 (issue 15): bench/gpu/multi_gpu_bench.sh
  local t0=$SECONDS
  unpack_cli_bundle || return 0
  ( export OPAL_PREFIX=$CLI_DIR/ompi PATH=$CLI_DIR/ompi/bin:$PATH \
      LD_LIBRARY_PATH=$CLI_DIR/ompi/lib/x86_64-linux-gnu:$LD_LIBRARY_PATH OMPI_MCA_btl=self,vader TMPDIR=/tmp
    bash "$ROOT/bench/gpu/multi_gpu_bench.sh" "$CLI_DIR/ompi/bin" "$DEPS/meshes" ) > "$OUT/multigpu.log" 2>&1
  say "multigpu: rc=$? in $((SECONDS - t0)) s"
  grep -E "K=|skipped|FAILED" "$OUT/multigpu.log" | tee -a "$SUMMARY"
}

step_labels() { # CUDA == CPU labelled builds, and labelled vs plain CUDA builds (issue 17): bench/run_label_bench.py
  local t0=$SECONDS
  run_tests label-tests '*CudaLabels*' "${TESTS_TIMEOUT:-240}"
  unpack_cli_bundle || return 0
  LD_LIBRARY_PATH=$CLI_DIR/ompi/lib/x86_64-linux-gnu:$LD_LIBRARY_PATH timeout "${LABELS_TIMEOUT:-300}" \
    python3 "$ROOT/bench/run_label_bench.py" --tool "$CLI_DIR/ompi/bin/hdt-voxelize" --meshes "$DEPS/meshes" \
    --backend cuda --sizes ${LABELS_RES:-2048 4096 8192} --repeat 3 --out "$OUT/labels-gpu.md" > "$OUT/labels-gpu.log" 2>&1
  say "labels bench: rc=$? in $((SECONDS - t0)) s"
  tail -12 "$OUT/labels-gpu.log" | tee -a "$SUMMARY"
}

step_labelbin() { # labelled vs plain CUDA builds with the hdt-voxelize in $BIN (built here, carried: no
  # MPI bundle needed); LABELS_RES, LABELS_REPEAT, LABELS_TIMEOUT
  local t0=$SECONDS
  timeout "${LABELS_TIMEOUT:-300}" python3 "$ROOT/bench/run_label_bench.py" --tool "$BIN/hdt-voxelize" \
    --meshes "$DEPS/meshes" --backend cuda --sizes ${LABELS_RES:-2048 4096 8192} --repeat "${LABELS_REPEAT:-3}" \
    --out "$OUT/labels-gpu.md" > "$OUT/labels-gpu.log" 2>&1
  say "labelbin bench: rc=$? in $((SECONDS - t0)) s"
  tail -12 "$OUT/labels-gpu.log" | tee -a "$SUMMARY"
}

step_winding() {
  run_tests winding-tests '*CudaWinding*' "${TESTS_TIMEOUT:-240}"
  local t0=$SECONDS args=()
  for m in ${WINDING_MESHES:-teapot.ply ogre.ply}; do args+=(--mesh "$m"); done
  timeout "${WINDING_TIMEOUT:-240}" "$BENCH" --meshes "$DEPS/meshes" "${args[@]}" --res "${WINDING_RES:-128,256}" \
    --root 8 --modes solid,winding --runs 1 --out "$OUT/winding-gpu.jsonl" > "$OUT/winding-gpu.log" 2>&1
  say "winding bench: rc=$? in $((SECONDS - t0)) s"
  tail -8 "$OUT/winding-gpu.log" | tee -a "$SUMMARY"
}

for s in "$@"; do "step_$s"; done
echo
cat "$SUMMARY"
