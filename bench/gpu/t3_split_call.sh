#!/usr/bin/env bash
# T3 scratch variants against base, one device call (branch s11-18c): from a folder holding bin-NAME/hdt_gpu_bench.xz
# (NAME in V, base first) two levels below the repository root with .devdeps carried; OUT=... V="base skip1" bash t3_split_call.sh
set -u
R=$(cd ../.. && pwd)
export LD_LIBRARY_PATH=$R/.devdeps/lib/x86_64-linux-gnu:/usr/local/cuda/lib64:${LD_LIBRARY_PATH:-}
export PATH=/usr/local/cuda/bin:$PATH
for b in bin-*; do xz -d -k -f $b/hdt_gpu_bench.xz; chmod +x $b/hdt_gpu_bench; done
nvidia-smi --query-gpu=name,driver_version,clocks.sm --format=csv,noheader | tee $OUT/info.txt
date -u | tee -a $OUT/info.txt
V=${V:-"base skip1 skip2 skip3 skip4"}
for r in 1 2; do for v in $V; do
  timeout 100 bin-$v/hdt_gpu_bench --meshes $R/.devdeps/meshes --mesh cycloidal-drive.ply --res 8192 --modes solid --runs 5 --out $OUT/ab-$v.jsonl > /dev/null 2>> $OUT/err.txt || echo "rc=$? $v" >> $OUT/err.txt
done; done
for v in $V; do
  timeout 60 ncu --clock-control none -k regex:leafKernel --metrics gpu__time_duration.sum,smsp__inst_executed.sum,smsp__thread_inst_executed.sum -c 3 --csv \
    bin-$v/hdt_gpu_bench --meshes $R/.devdeps/meshes --mesh cycloidal-drive.ply --res 8192 --modes solid --runs 2 --out /tmp/x.jsonl 2>>$OUT/err.txt | grep '^"' > $OUT/ncu-$v.csv
done
python3 - $OUT $V <<'PY' | tee $OUT/summary.txt
import json, sys, statistics, csv
d, vs = sys.argv[1], sys.argv[2:]
for v in vs:
    rs = [json.loads(l) for l in open(f"{d}/ab-{v}.jsonl")]
    med = lambda k: statistics.median(r["time_ms"][k] for r in rs)
    rows = list(csv.reader(open(f"{d}/ncu-{v}.csv")))
    h = rows[0]; mi = h.index('Metric Name'); vi = h.index('Metric Value')
    m = {}
    for r in rows[1:]: m.setdefault(r[mi], []).append(float(r[vi].replace(',', '')))
    t = statistics.median(m.get('gpu__time_duration.sum', [0]))
    ins = statistics.median(m.get('smsp__inst_executed.sum', [0])); thr = statistics.median(m.get('smsp__thread_inst_executed.sum', [0]))
    print(f"{v:6} n={len(rs)} total {med('total'):.3f} T3 {med('leaf'):.3f} cls {med('classify'):.3f} T2 {med('branching'):.3f} | ncu T3 {t/1e6 if t>1e4 else t:.3f} inst {ins/1e9:.3f} G lanes {thr/max(ins,1):.1f}")
PY
