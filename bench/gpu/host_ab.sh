#!/usr/bin/env bash
# The host path of a base build and a new one, side by side on the GPU
# machine, alternating run by run (issue 18: prepare's first call, the copy
# back into warm pages, the CLI's process wall):
#
#   OUT=... bench/gpu/host_ab.sh BASE_DIR NEW_DIR
#
# Each DIR holds hdt_e2e_bench and hdt-voxelize built for this machine.
#   HOST_AB_E2E  "MESH:SUBDIVIDE:N:MODE[:FLAGS] ..." (FLAGS as device-run.sh e2e; flags
#                only NEW knows are given to NEW alone after a '+': e.g. dragon:0:8192:solid:+no-release)
#   HOST_AB_CLI  "MESH:N ..."; HOST_AB_REPEAT runs of each (default 3)
# Writes $OUT/host-ab-e2e.jsonl and $OUT/host-ab-cli.jsonl (key "variant": base or new),
# and checks that base and new write the same .hdt bytes (hdt_same.py: all sections but
# the run's statistics).
set -u -o pipefail
BASE=$1 NEW=$2
ROOT=$(pwd)
DEPS=$ROOT/.devdeps
OUT=${OUT:-$ROOT/device-out}
mkdir -p "$OUT"
export LD_LIBRARY_PATH=$DEPS/lib/x86_64-linux-gnu:/usr/local/cuda/lib64:${LD_LIBRARY_PATH:-}
SUMMARY=$OUT/summary.txt
say() { echo "== $*" | tee -a "$SUMMARY"; }
now() { date +%s.%N; }

tag() { # FILE VARIANT: adds "variant" to the last line of FILE
  python3 - "$1" "$2" <<'PY'
import json, sys
lines = open(sys.argv[1]).read().splitlines()
d = json.loads(lines[-1]); d['variant'] = sys.argv[2]
lines[-1] = json.dumps(d); open(sys.argv[1], 'w').write('\n'.join(lines) + '\n')
PY
}

e2e_one() { # VARIANT DIR SPEC
  local variant=$1 dir=$2 spec=$3 m k n mode flag extra=() f
  IFS=: read -r m k n mode flag <<< "$spec"
  for f in ${flag//,/ }; do
    if [[ $f == +* ]]; then [ "$variant" = new ] || continue; f=${f#+}; fi
    extra+=("--${f%%=*}"); [[ $f == *=* ]] && extra+=("${f#*=}")
  done
  timeout 120 "$dir/hdt_e2e_bench" "$DEPS/meshes/$m" --subdivide "$k" --res "$n" --mode "$mode" --backend cuda \
    --hdt /tmp/host-ab.hdt --out "$OUT/host-ab-e2e.jsonl" "${extra[@]}" >> "$OUT/host-ab.log" 2>&1 || say "e2e $variant rc=$? $spec"
  tag "$OUT/host-ab-e2e.jsonl" "$variant"
  python3 - "$OUT/host-ab-e2e.jsonl" "$spec" <<'PY' | tee -a "$SUMMARY"
import json, sys
r = json.loads(open(sys.argv[1]).read().splitlines()[-1])
p = r.get('prepare_parts_ms', {})
print(f"e2e {r['variant']:4} {sys.argv[2]:44} prep {r.get('prepare_ms', -1):6.2f} (only {r.get('prepare_only_ms', -1):6.2f} parts {' '.join('%.2f' % v for v in p.values())})"
      f" best {r.get('prepare_best_ms', -1):5.2f} wait {r.get('warm_up_wait_ms', -1):6.1f} resv {r.get('reserve_wait_ms', -1):5.1f}"
      f" build {r.get('build_wall_ms', -1):6.1f} copy {r.get('copy_back_ms', -1):6.1f} ({r.get('copy_back_gb_per_s', -1):5.1f} GB/s)"
      f" write {r.get('write_ms', -1):6.1f} rel {r.get('release_wait_ms', -1):5.1f} wall {r.get('wall_ms', -1):6.1f}"
      f" host {r.get('peak_host_bytes', 0) / 2**30:5.2f} GiB {r.get('error', '')}")
PY
}

cli_one() { # VARIANT DIR MESH N
  local variant=$1 dir=$2 m=$3 n=$4 s e
  s=$(now)
  "$dir/hdt-voxelize" "$DEPS/meshes/$m" --resolution "$n" --backend cuda -o "/tmp/host-ab-$variant.hdt" --json \
    > /tmp/host-ab-cli.json 2>> "$OUT/host-ab.log" || say "cli $variant rc=$? $m $n"
  e=$(now)
  python3 - "$s" "$e" "$variant" "$m" "$n" >> "$OUT/host-ab-cli.jsonl" <<'PY'
import json, sys
s, e = float(sys.argv[1]), float(sys.argv[2])
d = json.load(open('/tmp/host-ab-cli.json'))
d['variant'] = sys.argv[3]; d['process_wall_ms'] = round((e - s) * 1000, 1)
io = d['io_ms']
if 'unix_at_main' in io:
    d['before_main_ms'] = round(io['unix_at_main'] - s * 1000, 1)
    d['after_report_ms'] = round(e * 1000 - io['unix_at_report'], 1)
print(json.dumps(d))
PY
  python3 - "$OUT/host-ab-cli.jsonl" <<'PY' | tee -a "$SUMMARY"
import json, sys
d = json.loads(open(sys.argv[1]).read().splitlines()[-1]); io = d['io_ms']
print(f"cli {d['variant']:4} {d['mesh'].split('/')[-1]:26} wall {d['process_wall_ms']:6.1f} before main {d.get('before_main_ms', -1):5.1f}"
      f" main {io['since_start']:6.1f} after {d.get('after_report_ms', -1):6.1f} | read {io['read']:5.1f} prep {io['prepare']:5.1f}"
      f" dev {io['device_wait']:6.1f} resv {io.get('reserve_wait', -1):5.1f} build {io['build']:6.1f} write {io['write']:6.1f}"
      f" est {io['estimate_wait']:5.1f} rel {io.get('release_wait', -1):5.1f} host {d['peak_host_bytes'] / 2**30:5.2f} GiB")
PY
}

t0=$SECONDS
for spec in ${HOST_AB_E2E:-}; do
  for k in $(seq "${HOST_AB_REPEAT:-3}"); do
    e2e_one base "$BASE" "$spec"
    e2e_one new "$NEW" "$spec"
  done
done
say "e2e done in $((SECONDS - t0)) s"
t0=$SECONDS
for spec in ${HOST_AB_CLI:-}; do
  IFS=: read -r m n <<< "$spec"
  for k in $(seq "${HOST_AB_REPEAT:-3}"); do
    cli_one base "$BASE" "$m" "$n"
    cli_one new "$NEW" "$m" "$n"
  done
  say "$m $n: $(python3 bench/gpu/hdt_same.py /tmp/host-ab-base.hdt /tmp/host-ab-new.hdt)"
  rm -f /tmp/host-ab-base.hdt /tmp/host-ab-new.hdt
done
say "cli done in $((SECONDS - t0)) s"
