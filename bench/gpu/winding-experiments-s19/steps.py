#!/usr/bin/env python3
"""The winding pass's steps per process from a call's bench.log (the files'
logs joined under "=== NAME-ROUND.log" headers, HDT_WINDING_TRACE on): per
8192^3 build (the last of each mesh's runs), the uniform passes (device
events), the surface leaves' box step and the fresh leaves' kernels, ms."""
import re, sys
from collections import defaultdict

rows = defaultdict(list)  # (variant, fresh leaves) -> [(uniform, decide, fresh)]
cur = None
for line in open(sys.argv[1]):
    if line.startswith("=== "):
        cur = line.split()[1][: -len(".log")].rsplit("-", 1)[0]
        continue
    m = re.search(r"fresh kernels ([0-9.]+) ms, (\d+) leaves", line)
    if m:
        fresh = (float(m.group(1)), int(m.group(2)))
    m = re.search(r"on the device \(ms\): uniform ([0-9.]+),.* decide ([0-9.]+) \(", line)
    if m and fresh[1] > 0:
        rows[(fresh[1], cur)].append((float(m.group(1)), float(m.group(2)), fresh[0]))
print("fresh leaves (mesh) variant | uniform | box step | fresh kernels (ms, every build)")
for key in sorted(rows):
    v = rows[key]
    cols = [" ".join("%.1f" % x[i] for x in v) for i in range(3)]
    print("%d %s | %s | %s | %s" % (key[0], key[1], *cols))
