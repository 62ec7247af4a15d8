# Summary of call.sh's A/B: per (mesh, res, mode) time_ms.total and
# peak_device_bytes of each binary and round, the inside counts compared, and
# the winding leaf pass's counts / decide times from the driver's log lines.
import json, re, sys, glob, os
work, merged = sys.argv[1], sys.argv[2]
# the two binaries' names (call.sh: A_NAME, B_NAME)
a, b = (sys.argv[3], sys.argv[4]) if len(sys.argv) > 4 else ("main", "mem")
rows = {}
with open(merged, "w") as out:
    for path in sorted(glob.glob(os.path.join(work, "*-?.jsonl"))):
        binary, rnd = os.path.basename(path)[:-6].rsplit("-", 1)
        for line in open(path):
            line = line.strip()
            if not line: continue
            d = json.loads(line)
            d["binary"], d["round"] = binary, int(rnd)
            out.write(json.dumps(d) + "\n")
            key = (d["mesh"], d["resolution"], d.get("mode", "?"))
            rows.setdefault(key, {})[(binary, int(rnd))] = d
steps, held, kept = {}, {}, {}
for path in sorted(glob.glob(os.path.join(work, "*-?.log"))):
    binary, rnd = os.path.basename(path)[:-4].rsplit("-", 1)
    current = None
    for line in open(path):
        m = re.match(r"(\S+)\s+(\d+)\s+(solid|winding|surface)\s", line)
        if m: current = (m.group(1), int(m.group(2)), m.group(3))
        m = re.search(r"crossings ([0-9.]+), lines ([0-9.]+), counts ([0-9.]+), decide ([0-9.]+)", line)
        if m and current: steps[(current, binary, int(rnd))] = tuple(float(x) for x in m.groups())
        m = re.search(r"held at most ([0-9]+) bytes", line)
        if m and current: held[(current, binary, int(rnd))] = int(m.group(1))
        m = re.search(r"winding trace leaves: ([0-9]+) leaves.* ([0-9]+) leaves keep counts \(([0-9.]+) MB\)", line)
        if m: kept[(binary, int(rnd), int(m.group(1)))] = (int(m.group(2)), float(m.group(3)))
cols = [(a, 1), (b, 1), (b, 2), (a, 2)]
print("mesh res mode | ms total: %s1 %s1 %s2 %s2 | peak MB: %s %s | inside equal" % (a, b, b, a, a, b))
for key in sorted(rows):
    r = rows[key]
    ms = " ".join("%.1f" % r[c]["time_ms"]["total"] if c in r and "time_ms" in r[c] else "-" for c in cols)
    peak = " ".join("%.0f" % (r[c]["peak_device_bytes"] / 1e6) if c in r and "peak_device_bytes" in r[c] else "-"
                    for c in [(a, 1), (b, 1)])
    inside = set(r[c].get("inside_voxels") for c in r)
    print("%s %d %s | %s | %s | %s" % (key[0], key[1], key[2], ms, peak, "yes" if len(inside) == 1 else inside))
print("winding leaf pass (crossings, lines, counts, decide ms; the last run's log):")
for (k, b, rnd), v in sorted(steps.items()):
    print("  %s %d %s %s%d: %s" % (k[0], k[1], k[2], b, rnd, " ".join("%.2f" % x for x in v)))
print("the device passes' own peak (the log, last run), MB:")
for (k, b, rnd), v in sorted(held.items()):
    print("  %s %d %s %s%d: %.1f" % (k[0], k[1], k[2], b, rnd, v / 1e6))
print("leaves keeping counts (the trace; leaves: kept, counts MB), distinct:")
for (b, rnd, leaves), v in sorted(kept.items()):
    if rnd == 1: print("  %d leaves: %d keep counts, %.1f MB" % (leaves, v[0], v[1]))
