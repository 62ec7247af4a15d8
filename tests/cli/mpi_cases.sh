#!/bin/bash
# mpi_cases.sh HDT_VOXELIZE HDT_VOXELIZE_MPI WORK: mpiexec -n K hdt-voxelize-mpi
# (K = 1..4, oversubscribed: CI has 2 cores) writes the same volume as the
# serial hdt-voxelize, for a closed mesh, a knot, an open mesh (Parity asked
# for: 3-axis classification, parities cross ranks; Auto: the winding number,
# which rank 0 runs on the joined surface), a surface-only build and a grid
# with one row of root cells (more ranks than rows). compare_hdt.py compares every
# section but the run's own measurements (times, memory, threads).
set -euo pipefail
serial=$1 mpi=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
rm -rf "$work" && mkdir -p "$work" && cd "$work"
# An open cap (no bottom): a triangle fan of a sphere's upper half.
python3 - <<'PY'
import math
rings, seg = 12, 32
pts, tris = [(0.0, 0.0, 1.0)], []
for i in range(1, rings + 1):
    t = 0.5 * math.pi * i / rings
    for j in range(seg):
        p = 2 * math.pi * j / seg
        pts.append((math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)))
for j in range(seg):
    tris.append((0, 1 + j, 1 + (j + 1) % seg))
for i in range(rings - 1):
    a, b = 1 + i * seg, 1 + (i + 1) * seg
    for j in range(seg):
        k = (j + 1) % seg
        tris += [(a + j, b + j, b + k), (a + j, b + k, a + k)]
with open("cap.obj", "w") as f:
    f.writelines("v %r %r %r\n" % p for p in pts)
    f.writelines("f %d %d %d\n" % (a + 1, b + 1, c + 1) for a, b, c in tris)
PY
run_case() { # name mesh args...
  local name=$1 mesh=$2
  shift 2
  "$serial" "$mesh" "$@" --backend cpu --quiet -o "$name-serial.hdt" > /dev/null
  for k in 1 2 3 4; do
    mpiexec --oversubscribe -n $k "$mpi" "$mesh" "$@" --backend cpu --quiet -o "$name-$k.hdt" > /dev/null
    python3 "$here/compare_hdt.py" "$name-serial.hdt" "$name-$k.hdt" > /dev/null
    echo "mpi_cases: $name on $k ranks: same volume"
  done
}
run_case sphere builtin:sphere --resolution 128 --root-grid 4 --leaf-size 8
run_case knot builtin:knot --resolution 128 --root-grid 8 --leaf-size 8
run_case cap cap.obj --resolution 128 --root-grid 4 --leaf-size 8 --inside-test parity
run_case surface builtin:torus --resolution 128 --root-grid 4 --leaf-size 8 --surface-only
run_case onerow builtin:sphere --resolution 64 --root-grid 1 --leaf-size 16
# Auto (the default) on the open cap: the winding number, across ranks too.
run_case capwinding cap.obj --resolution 128 --root-grid 4 --leaf-size 8
mpiexec --oversubscribe -n 2 "$mpi" cap.obj --resolution 128 --root-grid 4 --leaf-size 8 --backend cpu --quiet \
  --json > cap-auto.json
python3 - cap-auto.json <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
assert r["inside_test"] == "winding" and r["inside_test_requested"] == "auto", r["inside_test"]
assert r["inside_test_reason"] == "Auto: the mesh is open, winding number", r["inside_test_reason"]
assert not r["warnings"], r["warnings"]
assert r["inside_voxels"] > 0, r["inside_voxels"]
PY
echo "mpi_cases: Auto on an open mesh across ranks: the winding number"
# The per-rank report: one row a rank, whose ranges cover the root grid and
# whose leaf grids add up to the volume's.
mpiexec --oversubscribe -n 3 "$mpi" builtin:knot --resolution 128 --root-grid 8 --leaf-size 8 --backend cpu \
  --quiet --json > ranks.json
python3 - ranks.json <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
ranks = r["ranks"]
assert len(ranks) == 3, ranks
assert [k["rank"] for k in ranks] == [0, 1, 2]
assert sum(k["root_cells"] for k in ranks) == r["root_grid"] ** 3, ranks
assert sum(k["leaf_grids"] for k in ranks) == r["leaf_grids"], (ranks, r["leaf_grids"])
assert all(k["backend"] == "cpu" and k["device"] == -1 and k["peak_host_bytes"] > 0 for k in ranks)
assert r["slowest_rank"] == max(range(3), key=lambda i: ranks[i]["time_ms"]["total"])
for phase in ("mapping", "branching", "leaf", "classify"):
    assert r["time_ms"][phase] == max(k["time_ms"][phase] for k in ranks), phase
PY
echo "mpi_cases: per-rank report"
# compare_hdt.py itself must see a difference, also when it leaves the
# statistics section out (--any-backend).
for flag in "" --any-backend; do
  if python3 "$here/compare_hdt.py" $flag sphere-serial.hdt knot-serial.hdt > /dev/null 2>&1; then
    echo "mpi_cases: compare_hdt.py $flag missed a difference"; exit 1
  fi
done
echo "mpi_cases: ok"
