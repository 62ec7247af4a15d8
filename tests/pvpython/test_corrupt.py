"""Damaged .hdt files: one clear error naming the file, an empty output, no crash.

A valid file is made (Sphere, N = 128, saved with the HDT Writer), then
damaged copies: truncated, empty, too short, bad magic, unknown version,
trailing bytes, a flipped bit in the statistics and in the leaf data, a
directory and a missing file. Each is opened by its own pvpython process (so a
crash is seen as such): the test checks its exit code, that stderr has exactly
one error (from the reader) naming the file with the expected reason, that the
output is empty, and that the valid file reads without any error.

Then one process reads 64 copies, each with one bit flipped at a position
spread evenly over the file: every byte of an .hdt file is covered by a check
(header fields or a CRC-32), so every one of them must be refused.
"""
import os
import re
import subprocess
import sys

if "--child" in sys.argv:
    # Child mode: read each file given after --child with one HDT Reader and
    # print "CELLS <file> <number of cells>".
    from paraview import simple

    i = sys.argv.index("--child")
    simple.LoadPlugin(sys.argv[i + 1], remote=False, ns=globals())
    reader = None
    for path in sys.argv[i + 2:]:
        if reader is None:
            reader = globals()["HDTReader"](FileName=path)
        else:
            reader.FileName = path
        reader.UpdatePipeline()
        print("CELLS %s %d" % (path, reader.GetDataInformation().GetNumberOfCells()), flush=True)
    sys.exit(0)

from paraview.simple import *  # noqa: E402,F401,F403

import hdt_testing as t  # noqa: E402

args = t.parse_args()
t.load_plugin(args.plugin, globals())
pvpython = os.environ.get("HDT_PVPYTHON", "pvpython")

sphere = Sphere(ThetaResolution=32, PhiResolution=32)
vox = HDTVoxelizer(Input=sphere, Resolution=128, RootGridSize=16, LeafGridSize=8, Backend="CPU")
good = os.path.join(args.tmp, "good.hdt")
SaveData(good, proxy=vox)
with open(good, "rb") as f:
    data = f.read()
t.check(len(data) > 1000, "valid file written (%d bytes)" % len(data))


def damaged(name, content):
    path = os.path.join(args.tmp, name)
    with open(path, "wb") as f:
        f.write(content)
    return path


def flip(offset, bit=0):
    b = bytearray(data)
    b[offset] ^= 1 << bit
    return bytes(b)


# Statistics payload: right after the 12-byte file header, the 28-byte grid
# section header, the 56-byte grid payload and the statistics' section header.
stats_offset = 12 + 28 + 56 + 28 + 8
cases = [
    # name, content, expected words in the message
    ("truncated.hdt", data[: len(data) // 2], "truncated"),
    ("empty.hdt", b"", "too short"),
    ("short.hdt", data[:10], "too short"),
    ("magic.hdt", b"PK\x03\x04" + data[4:], "magic"),
    ("version.hdt", flip(4, 3), "version"),  # 2 or 3 -> 10 or 11
    ("trailing.hdt", data + b"\0", "after the end"),
    ("stats-bit.hdt", flip(stats_offset, 3), "CRC-32"),
    # The file ends with the leaf data, then the 28-byte end section (format versions 2 and 3).
    ("leaf-bit.hdt", flip(len(data) - 28 - 17, 5), "CRC-32"),
]


def read(paths):
    cmd = [pvpython, os.path.abspath(__file__), "--child", args.plugin] + paths
    return subprocess.run(cmd, capture_output=True, text=True, timeout=600)


def errors_about(stderr, path):
    plain = re.sub(r"\x1b\[[0-9;]*m", "", stderr)  # loguru's colours
    return [line for line in plain.splitlines() if "ERR|" in line and path + ":" in line]


# --- the valid file -------------------------------------------------------------------
r = read([good])
t.check_equal(r.returncode, 0, "valid file: exit code")
t.check("CELLS %s 0" % good not in r.stdout and "CELLS " + good in r.stdout, "valid file: cells read")
t.check("ERR|" not in r.stderr, "valid file: no error")

# --- each damage in its own process ----------------------------------------------------
directory = os.path.join(args.tmp, "directory.hdt")
os.makedirs(directory, exist_ok=True)
paths = [(damaged(name, content), reason) for name, content, reason in cases]
paths += [(directory, "not a regular file"),
          (os.path.join(args.tmp, "missing.hdt"), "No such file")]
for path, reason in paths:
    name = os.path.basename(path)
    r = read([path])
    t.check_equal(r.returncode, 0, "%s: exit code (no crash)" % name)
    t.check("CELLS %s 0\n" % path in r.stdout, "%s: empty output" % name)
    errors = errors_about(r.stderr, path)
    t.check(len(errors) == 1 and reason in errors[0],
            "%s: one error naming the file, with '%s': %s"
            % (name, reason, errors[0].split("): ", 1)[-1] if errors else r.stderr[-300:]))
    t.check("Traceback" not in r.stderr and "Signal" not in r.stderr, "%s: no traceback or signal" % name)

# --- every bit flip is refused -------------------------------------------------------------
flips = []
for k in range(64):
    offset = k * (len(data) - 1) // 63
    flips.append(damaged("flip-%02d.hdt" % k, flip(offset, k % 8)))
r = read(flips)
t.check_equal(r.returncode, 0, "64 bit flips in one process: exit code (no crash)")
refused = [p for p in flips if "CELLS %s 0\n" % p in r.stdout and len(errors_about(r.stderr, p)) == 1]
t.check_equal(len(refused), len(flips), "bit flips refused with one error each")
for p in flips:
    if p not in refused:
        print("   not refused: %s" % p)

t.finish()
