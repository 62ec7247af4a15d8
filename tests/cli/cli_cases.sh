#!/usr/bin/env bash
# Command-line tests of hdt-voxelize, one ctest case per function below.
#   cli_cases.sh CASE /path/to/hdt-voxelize WORKDIR
# Each case runs the tool, then checks the exit code, what it printed and what
# it wrote. A failed check prints what was expected and what came out.
set -euo pipefail

case_name=$1
tool=$2
work=$3
rm -rf "$work"
mkdir -p "$work"

fail() {
  echo "FAIL: $*" >&2
  echo "--- stdout:" >&2
  cat "$work/stdout" >&2 || true
  echo "--- stderr:" >&2
  cat "$work/stderr" >&2 || true
  exit 1
}

# run EXPECTED_EXIT ARGS...: runs the tool with stdout and stderr in files.
run() {
  local expected=$1
  shift
  local status=0
  "$tool" "$@" >"$work/stdout" 2>"$work/stderr" || status=$?
  [[ $status == "$expected" ]] || fail "hdt-voxelize $* exited $status, expected $expected"
}

stderr_has() { grep -qF -- "$1" "$work/stderr" || fail "stderr lacks '$1'"; }
stdout_has() { grep -qF -- "$1" "$work/stdout" || fail "stdout lacks '$1'"; }

# The JSON keys hdt-voxelize promises first, in this order (README.md).
required_keys='mesh triangles resolution root_grid leaf_size height origin voxel_size
  tree_elements leaf_grids leaf_voxels active_voxels inside_voxels paper_bits_per_active_voxel
  topology_bytes leaf_bytes backend threads time_ms peak_host_bytes degenerate_triangles
  closed_mesh peak_device_bytes'

case_help() {
  run 0 --help
  stdout_has "usage: hdt-voxelize MESH"
  stdout_has "--resolution"
  [[ ! -s $work/stderr ]] || fail "--help wrote to stderr"
}

case_bad_flag() {
  run 2 builtin:sphere --frobnicate
  stderr_has "unknown option '--frobnicate'"
}

case_bad_number() {
  run 2 builtin:sphere --resolution 12x
  stderr_has "--resolution expects an integer, got '12x'"
  run 2 builtin:sphere --threads
  stderr_has "--threads expects a value"
}

case_invalid_resolution() {
  # R = 16, L = 16: valid resolutions are 256, 512, 1024, ...
  run 2 builtin:sphere --resolution 1000
  stderr_has "resolution 1000"
  stderr_has "nearest valid: 512 or 1024"
}

case_unknown_builtin() {
  run 2 builtin:bunny --resolution 256
  stderr_has "unknown built-in mesh 'bunny' (available: sphere, torus, knot)"
}

case_missing_file() {
  run 3 "$work/no-such-mesh.stl" --resolution 256
  stderr_has "$work/no-such-mesh.stl: cannot open"
}

case_corrupt_file() {
  # 100 bytes: more than a binary STL header, but not 84 + 50 n.
  head -c 100 /dev/zero | tr '\0' 'x' >"$work/broken.stl"
  run 3 "$work/broken.stl" --resolution 256
  stderr_has "$work/broken.stl: truncated or corrupt binary STL"
}

case_json() {
  run 0 builtin:sphere --resolution 128 --root-grid 8 --json
  python3 -c 'import json, sys; json.load(sys.stdin)' <"$work/stdout" || fail "stdout is not JSON"
  python3 - "$work/stdout" $required_keys <<'EOF' || fail "JSON keys"
import json, sys
with open(sys.argv[1]) as f:
    doc = json.load(f)
required = sys.argv[2:]
keys = list(doc)
assert keys[: len(required)] == required, f"keys {keys[:len(required)]} != {required}"
assert list(doc["time_ms"]) == ["mapping", "branching", "leaf", "classify", "total"], doc["time_ms"]
assert len(doc["origin"]) == 3
assert doc["mesh"] == "builtin:sphere" and doc["resolution"] == 128 and doc["root_grid"] == 8
assert doc["triangles"] == 20480 and doc["closed_mesh"] is True
assert doc["active_voxels"] > 0 and doc["inside_voxels"] > 0
EOF
  [[ $(wc -l <"$work/stdout") == 1 ]] || fail "--json printed more than one line"
}

case_output() {
  run 0 builtin:torus --resolution 256 --quiet -o "$work/torus.hdt" --dense "$work/torus.nrrd"
  [[ -s $work/torus.hdt ]] || fail "-o wrote no file"
  [[ $(head -c 3 "$work/torus.hdt") == HDT ]] || fail "torus.hdt does not start with the HDT magic"
  [[ $(head -n 1 "$work/torus.nrrd") == NRRD0004 ]] || fail "torus.nrrd is not NRRD"
  grep -q '^sizes: 256 256 256$' "$work/torus.nrrd" || fail "torus.nrrd has the wrong sizes"
  [[ ! -s $work/stderr ]] || fail "--quiet still wrote to stderr"
  stdout_has "wrote"
}

# --compression-level: zstd's level of -o's leaf data; the default is level 1,
# 19 packs the same volume tighter; out-of-range levels are refused before the build.
case_compression_level() {
  for z in 0 -1 20; do
    run 2 builtin:torus --resolution 256 --compression-level "$z" -o "$work/bad.hdt"
    stderr_has "--compression-level must be at"
    [[ ! -e $work/bad.hdt ]] || fail "--compression-level $z wrote a file anyway"
  done
  run 0 builtin:torus --resolution 256 --quiet -o "$work/default.hdt"
  run 0 builtin:torus --resolution 256 --quiet --compression-level 1 -o "$work/level1.hdt"
  run 0 builtin:torus --resolution 256 --quiet --compression-level 19 -o "$work/level19.hdt"
  python3 "$(dirname "$0")/compare_hdt.py" "$work/default.hdt" "$work/level1.hdt" >/dev/null ||
    fail "the default level is not level 1"
  ! python3 "$(dirname "$0")/compare_hdt.py" "$work/default.hdt" "$work/level19.hdt" >/dev/null ||
    fail "--compression-level 19 wrote level 1's bytes"
  (($(stat -c %s "$work/level19.hdt") < $(stat -c %s "$work/default.hdt"))) ||
    fail "level 19 is not smaller than level 1"
  run 0 --help
  stdout_has "--compression-level"
}

case_dense_too_large() {
  run 2 builtin:sphere --resolution 2048 --dense "$work/big.nrrd"
  stderr_has "limited to N <= 1024"
  [[ ! -e $work/big.nrrd ]] || fail "wrote a file anyway"
}

# ---- issue 12 ----------------------------------------------------------------------

case_threads_bound() {
  for t in 257 10000000 1073741824 2147483647; do
    run 2 builtin:sphere --resolution 128 --root-grid 8 --threads "$t"
    stderr_has "--threads must be at most 256"
  done
  # The count used is recorded, and oversubscribing stays quiet under --quiet
  # (oneTBB printed "TBB Warning: The number of workers is currently limited").
  run 0 builtin:sphere --resolution 128 --root-grid 8 --threads 64 --quiet --json -o "$work/t.hdt"
  [[ ! -s $work/stderr ]] || fail "--quiet still wrote to stderr"
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["threads"] == 64, d["threads"]' \
    "$work/stdout" || fail "JSON threads is not 64"
}

case_output_checked_first() {
  # A missing directory is found before the build (exit 5), not after it.
  run 5 builtin:sphere --resolution 512 --root-grid 8 -o "$work/no/such/dir/x.hdt"
  stderr_has "$work/no/such/dir/x.hdt: cannot create a file in"
  [[ ! -s $work/stdout ]] || fail "built before checking the output"
  run 5 builtin:sphere --resolution 128 --root-grid 8 --dense "$work/no/dir/x.nrrd"
  mkdir "$work/adir"
  run 5 builtin:sphere --resolution 128 --root-grid 8 -o "$work/adir"
  stderr_has "is a directory"
  [[ -d $work/adir ]] || fail "the directory was removed"
}

case_refuse_input_overwrite() {
  "$tool" builtin:sphere --resolution 128 --root-grid 8 --quiet -o "$work/s.hdt" >/dev/null
  # A small binary STL (one triangle) as the input.
  python3 - "$work/in.stl" <<'EOF2'
import struct, sys
with open(sys.argv[1], "wb") as f:
    f.write(b"\0" * 80 + struct.pack("<I", 1))
    f.write(struct.pack("<12fH", 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0))
EOF2
  cp "$work/in.stl" "$work/in.copy"
  run 2 "$work/in.stl" --resolution 128 --root-grid 8 -o "$work/in.stl"
  stderr_has "is the input mesh; refusing to overwrite it"
  ln -s in.stl "$work/alias.hdt"
  run 2 "$work/in.stl" --resolution 128 --root-grid 8 --dense "$work/alias.hdt"
  cmp -s "$work/in.stl" "$work/in.copy" || fail "the input mesh changed"
}

case_write_failure_exit_code() {
  # Exit 5 for a write error (3 is for bad input). Under a file-size limit the
  # .hdt fits but the dense NRRD (2 MB) does not: neither output may appear,
  # and an existing -o file keeps its contents.
  echo old >"$work/v.hdt"
  local status=0
  (ulimit -f 1024; "$tool" builtin:torus --resolution 128 --root-grid 8 --quiet -o "$work/v.hdt" \
     --dense "$work/v.nrrd") >"$work/stdout" 2>"$work/stderr" || status=$?
  [[ $status == 5 ]] || fail "exited $status, expected 5"
  stderr_has "$work/v.nrrd: cannot write"
  [[ $(cat "$work/v.hdt") == old ]] || fail "the -o file changed although --dense failed"
  [[ ! -e $work/v.nrrd ]] || fail "a partial NRRD was left"
  [[ $(ls -A "$work" | wc -l) == 3 ]] || fail "temporary files were left: $(ls -A "$work")"
}

case_ply_hang() {
  # The 66-byte PLY of issue 12 looped 2^64 - 1 times.
  printf 'ply\nformat ascii 1.0\nelement junk 18446744073709551615\nend_header\n' >"$work/junk.ply"
  local status=0
  timeout 60 "$tool" "$work/junk.ply" --resolution 128 --root-grid 8 >"$work/stdout" 2>"$work/stderr" || status=$?
  [[ $status == 3 ]] || fail "exited $status, expected 3 (124: it hung)"
  stderr_has "declares 18446744073709551615 entries"
}

case_duplicate_warning() {
  # Every triangle twice: "closed" with nothing inside. Both facts are warned about.
  python3 - "$work/twice.stl" <<'EOF2'
import struct, sys
# a tetrahedron, each face written twice
p = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)] * 2
with open(sys.argv[1], "wb") as f:
    f.write(b"\0" * 80 + struct.pack("<I", len(faces)))
    for a, b, c in faces:
        f.write(struct.pack("<12fH", 0, 0, 0, *p[a], *p[b], *p[c], 0))
EOF2
  run 0 "$work/twice.stl" --resolution 128 --root-grid 8 --json
  stderr_has "warning: $work/twice.stl: 4 of 8 triangles repeat"
  stderr_has "closed but no voxel is inside"
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["duplicate_triangles"] == 4 and len(d["warnings"]) == 2, d' \
    "$work/stdout" || fail "JSON lacks the warnings"
  run 0 "$work/twice.stl" --resolution 128 --root-grid 8 --quiet
  [[ ! -s $work/stderr ]] || fail "--quiet still printed warnings"
}

case_labels() {
  # Two disjoint boxes in one PLY, labelled by a face property; the JSON table
  # adds up to the unlabelled counts, the label NRRD holds 2 N^3 bytes of data.
  python3 - "$work/two.ply" <<'EOF2'
import sys
pts, faces = [], []
for b, label in ((0, 4), (3, 9)):
    base = len(pts)
    pts += [(b + (i & 1), (i >> 1) & 1, (i >> 2) & 1) for i in range(8)]
    for q in ((0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)):
        faces.append(([base + k for k in q], label))
with open(sys.argv[1], "w") as f:
    f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
            "element face %d\nproperty list uchar int vertex_indices\nproperty ushort part\nend_header\n"
            % (len(pts), len(faces)))
    for p in pts: f.write("%g %g %g\n" % p)
    for q, l in faces: f.write("4 %s %d\n" % (" ".join(map(str, q)), l))
EOF2
  run 0 "$work/two.ply" --resolution 64 --root-grid 4 --leaf-size 8 --json
  cp "$work/stdout" "$work/plain.json"
  run 0 "$work/two.ply" --resolution 64 --root-grid 4 --leaf-size 8 --json --labels ply:part --overlap 9,4 \
    --dense-labels "$work/labels.nrrd" -o "$work/labels.hdt"
  python3 - "$work/plain.json" "$work/stdout" "$work/labels.nrrd" <<'EOF2' || fail "labels JSON or NRRD"
import json, sys
plain, lab = (json.load(open(p)) for p in sys.argv[1:3])
assert plain["labels"] is None and plain["label_bytes"] == 0, plain
labels = lab["labels"]
assert [l["label"] for l in labels] == [4, 9], labels
assert sum(l["surface_voxels"] for l in labels) == plain["active_voxels"]
assert sum(l["inside_voxels"] for l in labels) == plain["inside_voxels"]
assert lab["label_bytes"] > 0 and lab["dense_labels_file"] == sys.argv[3]
data = open(sys.argv[3], "rb").read()
header, body = data.split(b"\n\n", 1)
assert b"type: uint16" in header and len(body) == 2 * 64 ** 3, (header, len(body))
values = set(int.from_bytes(body[i:i + 2], "little") for i in range(0, len(body), 2))
assert values == {0, 4, 9}, values
EOF2
  run 2 "$work/two.ply" --overlap 0,1
  stderr_has "--overlap expects"
  run 2 "$work/two.ply" --labels bogus
  stderr_has "--labels expects"
  run 2 "$work/two.ply" --dense-labels "$work/x.nrrd"
  stderr_has "--dense-labels needs --labels"
  run 3 "$work/two.ply" --resolution 64 --root-grid 4 --labels ply:nothere
  stderr_has "no property 'nothere'"
}

case_transfer() {
  # A box in a PLY with a vertex property (t = x) and a face property (side):
  # --transfer carries them onto the surface voxels, the JSON names them and
  # their bytes, the .hdt file holds them.
  python3 - "$work/box.ply" <<'EOF2'
import sys
pts = [((i & 1), (i >> 1) & 1, (i >> 2) & 1) for i in range(8)]
quads = ((0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5))
with open(sys.argv[1], "w") as f:
    f.write("ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z\n"
            "property float t\nelement face 6\nproperty list uchar int vertex_indices\nproperty int side\nend_header\n")
    for p in pts: f.write("%g %g %g %g\n" % (p + (p[0],)))
    for k, q in enumerate(quads): f.write("4 %s %d\n" % (" ".join(map(str, q)), k))
EOF2
  run 0 "$work/box.ply" --resolution 32 --root-grid 2 --leaf-size 8 --json --transfer t --transfer side -o "$work/box.hdt"
  python3 - "$work/stdout" <<'EOF2' || fail "transfer JSON"
import json, sys
d = json.load(open(sys.argv[1]))
assert d["transferred_arrays"] == [{"name": "t", "source": "point", "components": 1},
                                   {"name": "side", "source": "cell", "components": 1}], d["transferred_arrays"]
assert d["transferred_array_bytes"] == 2 * 4 * d["active_voxels"] + 5, d
EOF2
  run 0 "$work/box.ply" --resolution 32 --root-grid 2 --leaf-size 8 --json
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["transferred_arrays"] == [] and d["transferred_array_bytes"] == 0, d' \
    "$work/stdout" || fail "arrays reported without --transfer"
  run 3 "$work/box.ply" --resolution 32 --root-grid 2 --transfer nothere
  stderr_has "no scalar vertex or face property 'nothere'"
  run 2 builtin:sphere --resolution 32 --root-grid 2 --transfer t
  stderr_has "--transfer needs a PLY file"
}

case_inside_test() {
  python3 - "$work/open.stl" <<'EOF2'
import struct, sys
# a tetrahedron without one face: open
p = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2)]
with open(sys.argv[1], "wb") as f:
    f.write(b"\0" * 80 + struct.pack("<I", len(faces)))
    for a, b, c in faces:
        f.write(struct.pack("<12fH", 0, 0, 0, *p[a], *p[b], *p[c], 0))
EOF2
  run 2 "$work/open.stl" --inside-test sometimes
  stderr_has "--inside-test expects auto, parity or winding, got 'sometimes'"
  run 0 "$work/open.stl" --resolution 64 --root-grid 4 --inside-test parity --json
  stderr_has "the mesh is open and the Parity inside test was asked for"
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["inside_test"] == "parity" and d["inside_test_requested"] == "parity", d' \
    "$work/stdout" || fail "JSON inside_test is not parity"
  run 0 "$work/open.stl" --resolution 64 --root-grid 4 --inside-test auto --json
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["inside_test"] == "winding" and d["inside_test_reason"].startswith("Auto: the mesh is open") and d["inside_voxels"] > 0, d' \
    "$work/stdout" || fail "Auto did not run the winding number on an open mesh"
  [[ $(grep -c "Parity inside test" "$work/stderr") == 0 ]] || fail "warned about parity under Auto"
  run 0 builtin:sphere --resolution 64 --root-grid 4 --inside-test auto
  stdout_has "Auto: the mesh is closed, exact ray parity"
  # Auto is the default: the open mesh gets the winding number, the closed one parity.
  run 0 "$work/open.stl" --resolution 64 --root-grid 4 --json
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["inside_test"] == "winding" and d["inside_test_requested"] == "auto", d' \
    "$work/stdout" || fail "the default did not run the winding number on an open mesh"
  [[ $(grep -c "Parity inside test" "$work/stderr") == 0 ]] || fail "warned about parity under the default"
  run 0 builtin:sphere --resolution 64 --root-grid 4 --json
  python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["inside_test"] == "parity" and d["inside_test_requested"] == "auto", d' \
    "$work/stdout" || fail "the default did not run parity on a closed mesh"
}

"case_${case_name//-/_}"
echo "ok: $case_name"
